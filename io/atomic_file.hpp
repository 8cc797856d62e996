#pragma once
/// @file atomic_file.hpp
/// Output files that appear whole or not at all: written to a temporary name, renamed on commit.

#include <array>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>
#include <thread>
#include <vector>

namespace bondem {

/// The write buffer of an AtomicFile, over an open file descriptor. A file that outgrows one
/// buffer (a checkpoint or final state of many particles) is written past the page cache
/// (`O_DIRECT`) where the file system allows it, in whole aligned buffers and a padded tail cut
/// back to the file's length: page-cache pages are fresh memory, which a virtual machine's host
/// backs slowly (the 423 MB of a 10^6-particle run's outputs took 0.55-0.72 s buffered against
/// 0.27-0.38 s direct on the development VM). Each full buffer is written by a thread of its own
/// while the caller fills the other one, so that formatting and the device overlap. Where direct
/// writes are refused (some file systems; tmpfs before Linux 6.6) it falls back to ordinary
/// writes. The
/// buffers (the second taken only once the first fills) come from a pool that maps them two at a
/// time in a span advised for transparent huge pages and keeps them for the process: mapped per
/// file, each fresh 1 MiB buffer cost 256 first touches, which the host backs at about 10 us each;
/// a one-step run of the 20 800 peer lattice mapped seven, half of its 2 000 page faults, and took
/// 63 ms against 45 ms with the pool (30 alternating runs, one thread). They stay resident: 4 MiB
/// for each file open at the same time.
/// Nothing reaches the file before a buffer fills or finish() runs: sync() writes nothing, so
/// an AtomicFile's temporary holds whole buffers only until its commit.
class FileWriteBuffer : public std::streambuf {
 public:
  /// Takes ownership of @p descriptor (open for writing; what the file holds is written over and
  /// cut at finish()).
  explicit FileWriteBuffer(int descriptor);
  ~FileWriteBuffer() override;
  FileWriteBuffer(const FileWriteBuffer&) = delete;
  FileWriteBuffer& operator=(const FileWriteBuffer&) = delete;

  /// Write what is buffered, cut the file to its length, clear O_DIRECT again and close the
  /// descriptor. False if anything failed.
  bool finish();

  /// Bytes of a buffer: the unit of a direct write, one huge page. A one-step run of the 998 400
  /// peer lattice (a 231 MB checkpoint, a 128 MB final state) took 0.90-0.93 of the time with 2
  /// MiB against 1 MiB on two threads, 0.94 on one (alternating runs): half the writing threads
  /// and waits for them, and direct writes of this VM's disk 1.3-1.6 GB/s at 1 MiB, 2.0 GB/s at 4
  /// MiB (`dd`). 4 MiB gave 0.87-0.89 but 5.5 MB more peak memory at 10^6 (2 MiB: 1.4 MB).
  static constexpr std::size_t kBufferBytes = std::size_t{1} << 21;

 protected:
  int_type overflow(int_type c) override;
  std::streamsize xsputn(const char* data, std::streamsize size) override;

 private:
  /// Hands the full buffer to a writing thread and continues in the other; false on an error.
  bool drain_full();
  /// Waits for the writing thread, if any; false if its write failed.
  bool wait_for_writer();
  /// Writes @p size bytes of @p data at @p offset, padded to whole blocks when direct.
  bool write_at(char* data, std::size_t size, std::size_t offset);

  int descriptor_;
  bool direct_ = false;  ///< whether the descriptor has O_DIRECT set
  bool failed_ = false;
  std::size_t written_ = 0;         ///< bytes of the file handed to writes so far
  std::array<char*, 2> buffers_{};  ///< the second mapped at the first drain
  std::size_t filling_ = 0;         ///< index of the buffer being filled
  std::thread writer_;
  bool writer_failed_ = false;  ///< set by writer_, read after joining it
};

/// A file written under `<path>.tmp.<pid>` and renamed to `path` by commit(). If commit() is never
/// reached (an error, an exception), the destructor removes the temporary: a failing run leaves no
/// truncated output behind.
class AtomicFile {
 public:
  /// Open the temporary file; creates missing parent directories. Throws std::runtime_error.
  /// Where an earlier run's file of @p path was offered for rewriting (offer_for_rewrite), that
  /// file is the temporary, written over from its start and cut to its new length at commit.
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// The stream to write to.
  std::ostream& stream() { return stream_; }
  /// Write, close and move into place. Throws std::runtime_error if writing failed.
  void commit();

 private:
  std::string path_;
  std::string temporary_;
  std::unique_ptr<FileWriteBuffer> buffer_;
  std::ostream stream_{nullptr};
  bool committed_ = false;
};

/// Offers @p aside, an earlier run's output @p original moved aside (a temporary of this process
/// that no other name links), to the next AtomicFile of @p original as its temporary: it writes
/// over the blocks the file holds, where a new file's blocks are allocated as it grows (256 MiB
/// of direct writes: 2.4-2.7 GB/s over an existing file against 1.4-2.0 GB/s into a new one on
/// this VM's disk), and the old file needs no unlink (which frees its blocks waiting on the disk
/// and slowed the first writes of the run beside it). Process-wide.
void offer_for_rewrite(const std::filesystem::path& original, const std::filesystem::path& aside);

/// Of the files @p asides offered by offer_for_rewrite, those no AtomicFile has taken, withdrawn
/// (for their owner to unlink).
std::vector<std::filesystem::path> withdraw_rewrites(
    const std::vector<std::filesystem::path>& asides);

}  // namespace bondem
