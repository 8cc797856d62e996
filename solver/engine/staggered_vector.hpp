#pragma once
/// @file staggered_vector.hpp
/// A std::vector whose large buffers start at staggered offsets within a page. glibc's malloc gives
/// every buffer above its mapping threshold (kOwnMappingBytes, which bondem sets) a mapping of its
/// own, so element i of every such array has the same address modulo 4 KiB and falls in the same
/// set of the 8-way L1 cache: a loop over more than 8 of them evicts its own lines. Measured on
/// the 998 400 lattice: one sweep over the 20 particle arrays of the drift ran 1.6 times slower
/// than with the arrays at distinct offsets. Smaller buffers come from malloc's heap, where their
/// sizes already spread their offsets. Addresses never reach a result.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace bondem {

/// Buffers of more than this many bytes get a mapping of their own from glibc's malloc, handed
/// back to the system when freed (app/main.cpp sets it with mallopt). Without a fixed threshold
/// glibc raises it (up to 32 MiB) after the first such buffer is freed, and the arrays that setup
/// frees afterwards (the case's particle list, a neighbor build's scratch) stay resident in the
/// heap: about 40 B a particle of a 10^6 run. 1 MiB: a particle array from about 131 000
/// particles on, above every per-step buffer.
inline constexpr std::size_t kOwnMappingBytes = std::size_t{1} << 20;
/// Offsets step by one cache line through one page: 64 distinct L1 sets.
inline constexpr std::size_t kStaggerStep = 64;
/// Distinct offsets in a 4 KiB page.
inline constexpr std::size_t kStaggerSlots = 4096 / kStaggerStep;

/// Transparent huge page size on x86-64 and arm64 Linux.
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;
/// Buffers of at least this many bytes start on a huge page boundary (plus their stagger offset)
/// and ask the kernel for huge pages. A 10^6 run's set-up spent about half its time in first-touch
/// page faults (4 KiB each, ~10 us apiece in a virtual machine); huge pages take 512 times fewer
/// (the loop's speed did not change measurably). Only whole huge pages inside a buffer are
/// advised, so a buffer must span at least one.
inline constexpr std::size_t kHugePageBufferBytes = kHugePageBytes + 4096;

/// Next stagger slot, round robin over the large buffers allocated so far.
inline std::size_t next_stagger_slot() {
  static std::atomic<std::size_t> counter{0};
  return counter.fetch_add(1, std::memory_order_relaxed) % kStaggerSlots;
}

/// Allocator of StaggeredVector: large buffers get a 64-B aligned start at the next slot's offset
/// and keep malloc's own pointer just before it, for deallocate.
template <class T>
struct StaggeredAllocator {
  static_assert(alignof(T) <= alignof(std::max_align_t), "malloc's alignment is all it gives");
  using value_type = T;

  StaggeredAllocator() = default;
  template <class U>
  StaggeredAllocator(const StaggeredAllocator<U>& /*other*/) {}  // NOLINT: rebinding converts

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kOwnMappingBytes) {
      if (void* plain = std::malloc(bytes > 0 ? bytes : 1)) return static_cast<T*>(plain);
      throw std::bad_alloc();
    }
    const bool huge = bytes >= kHugePageBufferBytes;
    // Room for malloc's pointer, the alignment (a huge page's when huge) and the largest offset.
    const std::size_t alignment = huge ? kHugePageBytes : kStaggerStep;
    const std::size_t padding = sizeof(void*) + alignment + 4096;
    if (bytes > static_cast<std::size_t>(PTRDIFF_MAX) - padding) throw std::bad_array_new_length();
    void* raw = std::malloc(bytes + padding);
    if (raw == nullptr) throw std::bad_alloc();
    const std::uintptr_t first = reinterpret_cast<std::uintptr_t>(raw) + sizeof(void*);
    const std::uintptr_t aligned = (first + alignment - 1) / alignment * alignment;
    const std::uintptr_t start = aligned + next_stagger_slot() * kStaggerStep;
#if defined(MADV_HUGEPAGE)
    if (huge) {
      // Only whole huge pages inside the buffer: the tail stays in small pages, so a buffer never
      // holds more resident memory than with small pages. Advised before malloc's pointer is
      // stored: a page touched before would keep its huge page small. Advice only: a kernel
      // without transparent huge pages refuses it and nothing changes.
      const std::uintptr_t end = (start + bytes) / kHugePageBytes * kHugePageBytes;
      if (end > aligned) madvise(reinterpret_cast<void*>(aligned), end - aligned, MADV_HUGEPAGE);
    }
#endif
    reinterpret_cast<void**>(start)[-1] = raw;
    return reinterpret_cast<T*>(start);
  }

  void deallocate(T* pointer, std::size_t n) {
    if (n * sizeof(T) < kOwnMappingBytes) {
      std::free(pointer);
    } else {
      std::free(reinterpret_cast<void**>(pointer)[-1]);
    }
  }

  template <class U>
  bool operator==(const StaggeredAllocator<U>& /*other*/) const {
    return true;
  }
  template <class U>
  bool operator!=(const StaggeredAllocator<U>& /*other*/) const {
    return false;
  }
};

/// A vector for the per-particle and per-pair arrays that the kernels stream side by side.
template <class T>
using StaggeredVector = std::vector<T, StaggeredAllocator<T>>;

/// Buffers of at least this many bytes are populated before they are first written.
inline constexpr std::size_t kPopulatedBytes = std::size_t{64} << 10;

/// Maps the whole pages of [@p start, @p start + @p bytes) writable, their contents unchanged, in
/// one call, where pages touched for the first time fault one at a time (about 10 us apiece in a
/// virtual machine; MADV_POPULATE_WRITE measured half of that per page here, host faults
/// included).
inline void populate(void* start, std::size_t bytes) {
  const auto first = (reinterpret_cast<std::uintptr_t>(start) + 4095) / 4096 * 4096;
  const auto end = (reinterpret_cast<std::uintptr_t>(start) + bytes) / 4096 * 4096;
#if defined(MADV_POPULATE_WRITE)
  if (end > first &&
      madvise(reinterpret_cast<void*>(first), end - first, MADV_POPULATE_WRITE) == 0) {
    return;
  }
#endif
  // Without it (an older kernel): write one byte of each page back to itself.
  for (std::uintptr_t page = first; page < end; page += 4096) {
    volatile unsigned char& byte = *reinterpret_cast<volatile unsigned char*>(page);
    byte = byte;
  }
}

/// @p v as @p n zeros. A buffer of kPopulatedBytes or more is new: the kernel maps and clears each
/// page at its first write, one fault per page, which for a serial assign() was a fifth of the
/// set-up of a 10^6 run on one thread while the others waited. Here every thread first populates
/// and clears the pages of its share of the raw storage (populate; a buffer below a 1 MiB piece
/// on the calling thread), then the assign runs over mapped pages.
template <class T>
void assign_zeros(StaggeredVector<T>& v, std::size_t n) {
  static_assert(std::is_trivially_copyable_v<T>, "zero bytes must be a value");
  if (n <= v.capacity() || n * sizeof(T) < kPopulatedBytes) {  // mapped already, or small
    v.assign(n, T{});
    return;
  }
  StaggeredVector<T>().swap(v);  // the old buffer goes first: never two at once
  StaggeredVector<T> fresh;
  fresh.reserve(n);
  auto* const bytes = reinterpret_cast<unsigned char*>(fresh.data());
  const std::size_t total = n * sizeof(T);
  constexpr std::size_t kPiece = std::size_t{1} << 20;
  const auto pieces = static_cast<std::int64_t>((total + kPiece - 1) / kPiece);
#pragma omp parallel for schedule(static) if (pieces > 1)
  for (std::int64_t k = 0; k < pieces; ++k) {
    const std::size_t first = static_cast<std::size_t>(k) * kPiece;
    const std::size_t size = std::min(first + kPiece, total) - first;
    populate(bytes + first, size);
    // The first write is what costs in a virtual machine (the host backs the page then: 32 MB
    // took 46 ms populated and then cleared on one thread, 27 ms with each thread clearing
    // the pieces it populated); the assign below writes them again at memory speed.
    std::memset(bytes + first, 0, size);
  }
  fresh.assign(n, T{});
  v.swap(fresh);
}

}  // namespace bondem
