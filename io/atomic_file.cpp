#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <new>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace bondem {

namespace {

/// Alignment of a direct write's memory, offset and length: the largest logical block in use.
constexpr std::size_t kDirectBlock = 4096;

/// Sets or clears O_DIRECT on @p descriptor; false if the file system refuses it.
bool set_direct(int descriptor, bool on) {
#ifdef O_DIRECT  // Linux; elsewhere every write goes through the cache
  const int flags = ::fcntl(descriptor, F_GETFL);
  if (flags < 0) return false;
  return ::fcntl(descriptor, F_SETFL, on ? (flags | O_DIRECT) : (flags & ~O_DIRECT)) == 0;
#else
  static_cast<void>(descriptor);
  return !on;
#endif
}

/// The write buffers that no file holds now, already touched: kept mapped for the process, so
/// that the next file does not fault them in again. As many as files were ever written at once
/// (two each).
class BufferPool {
 public:
  /// A buffer of FileWriteBuffer::kBufferBytes, page-aligned (direct writes need it): a kept one,
  /// else one of a new pair. Null if none can be mapped.
  char* take() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty() && !map_pair()) return nullptr;
    char* const buffer = free_.back();
    free_.pop_back();
    return buffer;
  }

  /// Keeps @p buffer (from take()) for the next file; unmaps it if the pool cannot grow.
  void give_back(char* buffer) noexcept {
    const std::lock_guard<std::mutex> lock(mutex_);
    try {
      free_.push_back(buffer);
    } catch (const std::bad_alloc&) {
      ::munmap(buffer, FileWriteBuffer::kBufferBytes);
    }
  }

 private:
  static constexpr std::size_t kPairBytes = 2 * FileWriteBuffer::kBufferBytes;

  /// Maps two buffers as one span aligned to kPairBytes, advised for transparent huge pages: a
  /// fault per huge page instead of per 4 KiB (a large file fills both). False if nothing was
  /// mapped.
  bool map_pair() {
    try {
      free_.reserve(free_.size() + 2);
    } catch (const std::bad_alloc&) {
      return false;
    }
    // Twice the span, then the unaligned head and tail given back.
    void* const memory =
        ::mmap(nullptr, 2 * kPairBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory == MAP_FAILED) return false;
    const auto start = reinterpret_cast<std::uintptr_t>(memory);
    const std::uintptr_t aligned = (start + kPairBytes - 1) / kPairBytes * kPairBytes;
    if (aligned > start) ::munmap(memory, aligned - start);
    if (aligned + kPairBytes < start + 2 * kPairBytes) {
      ::munmap(reinterpret_cast<void*>(aligned + kPairBytes),
               start + 2 * kPairBytes - aligned - kPairBytes);
    }
    char* const pair = reinterpret_cast<char*>(aligned);
#if defined(MADV_HUGEPAGE)
    ::madvise(pair, kPairBytes, MADV_HUGEPAGE);  // advice only: refused, small pages stay
#endif
    free_.push_back(pair);
    free_.push_back(pair + FileWriteBuffer::kBufferBytes);
    return true;
  }

  std::mutex mutex_;
  std::vector<char*> free_;
};

/// The process's pool. Never destroyed: a file may still be written from a static destructor,
/// and the mappings end with the process anyway.
BufferPool& buffer_pool() {
  static BufferPool* const pool = new BufferPool;
  return *pool;
}

/// The files offered by offer_for_rewrite and not yet taken: the original's path, the file.
struct Rewrites {
  std::mutex mutex;
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> offered;
};

/// The process's offers. Never destroyed, as buffer_pool().
Rewrites& rewrites() {
  static Rewrites* const offers = new Rewrites;
  return *offers;
}

/// The file offered for rewriting as @p original, taken from the offers; empty when none.
std::filesystem::path take_rewrite(const std::filesystem::path& original) {
  Rewrites& offers = rewrites();
  const std::lock_guard<std::mutex> lock(offers.mutex);
  const auto offer =
      std::find_if(offers.offered.begin(), offers.offered.end(),
                   [key = original.lexically_normal()](const auto& o) { return o.first == key; });
  if (offer == offers.offered.end()) return {};
  std::filesystem::path aside = std::move(offer->second);
  offers.offered.erase(offer);
  return aside;
}

}  // namespace

FileWriteBuffer::FileWriteBuffer(int descriptor) : descriptor_(descriptor) {
  buffers_[0] = buffer_pool().take();
  if (buffers_[0] == nullptr) {
    ::close(descriptor_);
    throw std::bad_alloc();
  }
  setp(buffers_[0], buffers_[0] + kBufferBytes);
}

FileWriteBuffer::~FileWriteBuffer() {
  wait_for_writer();
  if (descriptor_ >= 0) ::close(descriptor_);
  for (char* buffer : buffers_) {
    if (buffer != nullptr) buffer_pool().give_back(buffer);
  }
}

bool FileWriteBuffer::write_at(char* data, std::size_t size, std::size_t offset) {
  std::size_t length = size;
  if (direct_) {
    // A direct write takes whole blocks: the tail's padding is cut off by finish().
    length = (size + kDirectBlock - 1) / kDirectBlock * kDirectBlock;
    std::memset(data + size, 0, length - size);
  }
  std::size_t done = 0;
  while (done < length) {
    const ssize_t wrote =
        ::pwrite(descriptor_, data + done, length - done, static_cast<off_t>(offset + done));
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote < 0 && errno == EINVAL && direct_ && done == 0) {
      // The file system took O_DIRECT at fcntl but refuses the write: write through the cache.
      // Only the writing thread or, with it joined, finish() gets here.
      if (!set_direct(descriptor_, false)) return false;
      direct_ = false;
      length = size;
      continue;
    }
    if (wrote <= 0) return false;
    done += static_cast<std::size_t>(wrote);
  }
  return true;
}

bool FileWriteBuffer::wait_for_writer() {
  if (writer_.joinable()) writer_.join();
  if (writer_failed_) failed_ = true;
  return !failed_;
}

bool FileWriteBuffer::drain_full() {
  if (!wait_for_writer()) return false;
  if (buffers_[1] == nullptr && (buffers_[1] = buffer_pool().take()) == nullptr) {
    failed_ = true;
    return false;
  }
  // Only a file longer than one buffer goes direct: small files stay in the page cache, where
  // a write costs no device round trip.
  if (written_ == 0) direct_ = set_direct(descriptor_, true);
  char* const full = buffers_[filling_];
  const std::size_t offset = written_;
  written_ += kBufferBytes;
  writer_ = std::thread([this, full, offset] {
    if (!write_at(full, kBufferBytes, offset)) writer_failed_ = true;
  });
  filling_ = 1 - filling_;
  setp(buffers_[filling_], buffers_[filling_] + kBufferBytes);
  return true;
}

FileWriteBuffer::int_type FileWriteBuffer::overflow(int_type c) {
  if (pptr() == epptr() && !drain_full()) return traits_type::eof();
  if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
  *pptr() = traits_type::to_char_type(c);
  pbump(1);
  return c;
}

std::streamsize FileWriteBuffer::xsputn(const char* data, std::streamsize size) {
  std::streamsize done = 0;
  while (done < size) {
    if (pptr() == epptr() && !drain_full()) break;
    const std::streamsize room = std::min<std::streamsize>(size - done, epptr() - pptr());
    std::memcpy(pptr(), data + done, static_cast<std::size_t>(room));
    pbump(static_cast<int>(room));
    done += room;
  }
  return done;
}

bool FileWriteBuffer::finish() {
  if (descriptor_ < 0) return !failed_;
  bool written = wait_for_writer();
  const auto tail = static_cast<std::size_t>(pptr() - pbase());
  if (written && tail > 0) {
    written = write_at(pbase(), tail, written_);
    written_ += tail;
  }
  // A padded direct tail left whole blocks, and a file written over (offer_for_rewrite, the
  // last-good scratch) may be longer than what was put: cut the file back to the bytes put. Then
  // the open file is left as it came: a duplicate of its descriptor (LastGoodFile's) shares
  // O_DIRECT, and reads through it would have to be aligned.
  if (written) written = ::ftruncate(descriptor_, static_cast<off_t>(written_)) == 0;
  if (direct_ && !set_direct(descriptor_, false)) written = false;
  const bool closed = ::close(descriptor_) == 0;
  descriptor_ = -1;
  failed_ = !(written && closed);
  return !failed_;
}

AtomicFile::AtomicFile(std::string path)
    : path_(std::move(path)), temporary_(path_ + ".tmp." + std::to_string(::getpid())) {
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  std::error_code error;
  if (!parent.empty()) std::filesystem::create_directories(parent, error);
  if (error) throw std::runtime_error(path_ + ": cannot create directory: " + error.message());
  int descriptor = -1;
  if (const std::filesystem::path aside = take_rewrite(path_); !aside.empty()) {
    descriptor = ::open(aside.c_str(), O_WRONLY | O_CLOEXEC);
    if (descriptor >= 0) {
      temporary_ = aside.string();
    } else {
      std::filesystem::remove(aside, error);  // not to be had: a new temporary, as without it
    }
  }
  if (descriptor < 0) {
    descriptor = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  }
  if (descriptor < 0) throw std::runtime_error(path_ + ": cannot open for writing");
  buffer_ = std::make_unique<FileWriteBuffer>(descriptor);
  stream_.rdbuf(buffer_.get());
  stream_.precision(17);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    buffer_.reset();  // closes the temporary
    std::error_code ignored;
    std::filesystem::remove(temporary_, ignored);
  }
}

void AtomicFile::commit() {
  const bool written = static_cast<bool>(stream_) && buffer_->finish();
  if (!written) throw std::runtime_error(path_ + ": write failed");
  std::error_code error;
  std::filesystem::rename(temporary_, path_, error);
  if (error) throw std::runtime_error(path_ + ": cannot move into place: " + error.message());
  committed_ = true;
}

void offer_for_rewrite(const std::filesystem::path& original, const std::filesystem::path& aside) {
  Rewrites& offers = rewrites();
  const std::lock_guard<std::mutex> lock(offers.mutex);
  offers.offered.emplace_back(original.lexically_normal(), aside);
}

std::vector<std::filesystem::path> withdraw_rewrites(
    const std::vector<std::filesystem::path>& asides) {
  Rewrites& offers = rewrites();
  const std::lock_guard<std::mutex> lock(offers.mutex);
  std::vector<std::filesystem::path> withdrawn;
  std::erase_if(offers.offered, [&](const auto& offer) {
    if (std::find(asides.begin(), asides.end(), offer.second) == asides.end()) return false;
    withdrawn.push_back(offer.second);
    return true;
  });
  return withdrawn;
}

}  // namespace bondem
