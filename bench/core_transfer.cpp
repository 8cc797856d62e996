/// @file core_transfer.cpp
/// What moving a block of cache lines between two CPUs costs, the way two threads of a step hand
/// over the data where their shares meet. `bench_core_transfer [KIB [CPU_A CPU_B]]` (default 192
/// KiB, CPUs 0 and 1): a writer on CPU_B and a reader on CPU_A take turns over one buffer, and
/// the program prints the median time of each turn in microseconds:
///
/// - `write_owned_us`: the writer writes lines it wrote last (no other core holds them);
/// - `write_shared_us`: it writes lines the reader has just read (each store must first take
///   the line back from the other core's cache);
/// - `write_streamed_us`: the same with non-temporal stores (no read for ownership);
/// - `read_modified_us`: the reader reads lines the writer has just written, in order.
///
/// Why: bondem's two threads exchange the particles and force slots of the planes where their
/// shares meet, about 170 kB a step on the 20 800 peer lattice; what that costs per step, against
/// the step's time, depends on the host's placement of the vCPUs (bench_core_latency).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "pin_cpu.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace {

using bondem::bench::pin_to;

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Writes @p value + k into element k of @p buffer (@p count doubles, 16-B aligned), with
/// ordinary or non-temporal stores.
void write_buffer(double* buffer, std::size_t count, double value, bool streamed) {
#if defined(__SSE2__)
  if (streamed) {
    for (std::size_t k = 0; k + 2 <= count; k += 2) {
      _mm_stream_pd(buffer + k,
                    _mm_set_pd(value + static_cast<double>(k + 1), value + static_cast<double>(k)));
    }
    _mm_sfence();  // the lines reach memory before the reader's turn
    return;
  }
#else
  (void)streamed;  // ordinary stores only
#endif
  for (std::size_t k = 0; k < count; ++k) buffer[k] = value + static_cast<double>(k);
}

/// Sums @p count doubles of @p buffer in eight independent chains (a read at memory speed).
double read_buffer(const double* buffer, std::size_t count) {
  double sums[8] = {};
  for (std::size_t k = 0; k + 8 <= count; k += 8) {
    for (std::size_t l = 0; l < 8; ++l) sums[l] += buffer[k + l];
  }
  double total = 0.0;
  for (const double s : sums) total += s;
  return total;
}

double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 1 && argc != 2 && argc != 4) {
    std::fprintf(stderr, "usage: bench_core_transfer [KIB [CPU_A CPU_B]]\n");
    return 2;
  }
  const long kib = argc >= 2 ? std::atol(argv[1]) : 192;
  const int cpu_a = argc == 4 ? std::atoi(argv[2]) : 0;
  const int cpu_b = argc == 4 ? std::atoi(argv[3]) : 1;
  if (kib < 1 || kib > (1L << 20)) {
    std::fprintf(stderr, "bench_core_transfer: KIB must be 1 to %ld\n", 1L << 20);
    return 2;
  }
  const std::size_t count = static_cast<std::size_t>(kib) * 1024 / sizeof(double);
  std::vector<double> storage(count + 8);
  // 64-B aligned: whole lines, and the streaming stores' alignment.
  const auto address = (reinterpret_cast<std::uintptr_t>(storage.data()) + 63) / 64 * 64;
  double* const buffer = reinterpret_cast<double*>(address);
  if (!pin_to(cpu_a)) {
    std::fprintf(stderr, "bench_core_transfer: cannot run on CPU %d\n", cpu_a);
    return 2;
  }

  // Three turns a round: the writer writes the buffer twice (the second timed: lines it holds
  // alone), the reader reads it (timed: lines the other core has modified), the writer writes it
  // once more (timed: lines the reader holds too), with ordinary stores in even rounds and
  // streaming stores in odd ones.
  constexpr int kRounds = 400;
  std::atomic<int> turn{0};
  std::atomic<bool> pinned_b{true};
  std::vector<double> owned, shared, streamed, read_modified;
  double sink = 0.0;
  std::thread writer([&] {
    pinned_b = pin_to(cpu_b);
    for (int round = 0; round < kRounds; ++round) {
      while (turn.load(std::memory_order_acquire) != 3 * round) {
      }
      write_buffer(buffer, count, round, false);  // after a streamed turn, from memory: untimed
      double start = seconds_now();
      write_buffer(buffer, count, round + 0.5, false);
      owned.push_back(seconds_now() - start);
      turn.store(3 * round + 1, std::memory_order_release);  // the reader reads them
      while (turn.load(std::memory_order_acquire) != 3 * round + 2) {
      }
      start = seconds_now();
      write_buffer(buffer, count, round + 0.25, round % 2 == 1);
      (round % 2 == 1 ? streamed : shared).push_back(seconds_now() - start);
      turn.store(3 * round + 3, std::memory_order_release);
    }
  });
  for (int round = 0; round < kRounds; ++round) {
    while (turn.load(std::memory_order_acquire) != 3 * round + 1) {
    }
    const double start = seconds_now();
    sink += read_buffer(buffer, count);
    read_modified.push_back(seconds_now() - start);
    turn.store(3 * round + 2, std::memory_order_release);
  }
  writer.join();
  if (!pinned_b) {
    std::fprintf(stderr, "bench_core_transfer: cannot run on CPU %d\n", cpu_b);
    return 2;
  }
  std::printf("bytes = %zu\n", count * sizeof(double));
  std::printf("write_owned_us = %.1f\n", 1e6 * median(owned));
  std::printf("write_shared_us = %.1f\n", 1e6 * median(shared));
  std::printf("write_streamed_us = %.1f\n", 1e6 * median(streamed));
  std::printf("read_modified_us = %.1f\n", 1e6 * median(read_modified));
  volatile double kept = sink;  // the reads have a use
  (void)kept;
  return 0;
}
