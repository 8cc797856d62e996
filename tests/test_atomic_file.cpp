// AtomicFile and its FileWriteBuffer: the bytes put are the bytes in the file, whatever their
// number against the buffer's size and whether the file system takes direct writes.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "io/atomic_file.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

fs::path scratch_directory(const std::string& name) {
  const fs::path directory = testing::fresh_directory("atomic_file_" + name);
  fs::create_directories(directory);
  return directory;
}

/// @p size bytes that differ from block to block and from offset to offset, so that a block
/// written twice, dropped or shifted shows.
std::string pattern(std::size_t size) {
  std::string bytes(size, '\0');
  std::uint64_t state = 0x9e3779b97f4a7c15ULL;
  for (char& c : bytes) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    c = static_cast<char>(state >> 56);
  }
  return bytes;
}

/// Puts @p bytes in pieces of uneven sizes and single characters, as the writers do (numbers
/// formatted one by one, blocks of rows, raw arrays).
void put_in_pieces(std::ostream& out, const std::string& bytes) {
  std::size_t at = 0;
  std::size_t piece = 1;
  while (at < bytes.size()) {
    const std::size_t size = std::min(piece, bytes.size() - at);
    if (size == 1) {
      out.put(bytes[at]);
    } else {
      out.write(bytes.data() + at, static_cast<std::streamsize>(size));
    }
    at += size;
    piece = piece * 7 % 1000003 + 1;  // 1 to about a million bytes
  }
}

void expect_written_whole(const fs::path& directory, std::size_t size) {
  const fs::path path = directory / "out.bin";
  fs::remove(path);
  const std::string bytes = pattern(size);
  {
    AtomicFile file(path.string());
    put_in_pieces(file.stream(), bytes);
    EXPECT_FALSE(fs::exists(path)) << "visible before its commit";
    file.commit();
  }
  ASSERT_TRUE(fs::exists(path));
  EXPECT_EQ(fs::file_size(path), size);
  EXPECT_TRUE(testing::file_bytes(path) == bytes) << size << " bytes differ";
  // Nothing but the file: no temporary left beside it.
  EXPECT_EQ(std::distance(fs::directory_iterator(directory), fs::directory_iterator()), 1);
}

TEST(AtomicFile, SmallFileHoldsExactlyItsBytes) {
  const fs::path directory = scratch_directory("small");
  for (const std::size_t size :
       {std::size_t{0}, std::size_t{1}, std::size_t{4095}, std::size_t{4097}}) {
    expect_written_whole(directory, size);
  }
}

// Larger than the two buffers together and not a whole number of blocks: full buffers go to the
// writing thread (direct where the file system takes it), and the padded tail is cut back.
TEST(AtomicFile, FileOfSeveralBuffersHoldsExactlyItsBytes) {
  const fs::path directory = scratch_directory("large");
  constexpr std::size_t kBuffer = FileWriteBuffer::kBufferBytes;
  for (const std::size_t size : {kBuffer, kBuffer + 1, 2 * kBuffer, 5 * kBuffer / 2 + 123}) {
    expect_written_whole(directory, size);
  }
}

// The buffers are kept for the next file: two files open at once, filled in turns across several
// buffers each, must never be handed the same buffer (each would then hold the other's bytes).
TEST(AtomicFile, FilesOpenAtOnceKeepTheirOwnBytes) {
  const fs::path directory = scratch_directory("interleaved");
  constexpr std::size_t kBuffer = FileWriteBuffer::kBufferBytes;
  const std::string first = pattern(5 * kBuffer / 2 + 17);
  std::string second = pattern(3 * kBuffer + 5);
  std::reverse(second.begin(), second.end());
  {
    AtomicFile a((directory / "a.bin").string());
    AtomicFile b((directory / "b.bin").string());
    constexpr std::size_t kPiece = 100'003;  // not a divisor of a buffer: the turns straddle them
    for (std::size_t at = 0; at < std::max(first.size(), second.size()); at += kPiece) {
      if (at < first.size()) {
        a.stream().write(first.data() + at,
                         static_cast<std::streamsize>(std::min(kPiece, first.size() - at)));
      }
      if (at < second.size()) {
        b.stream().write(second.data() + at,
                         static_cast<std::streamsize>(std::min(kPiece, second.size() - at)));
      }
    }
    b.commit();
    a.commit();
  }
  EXPECT_TRUE(testing::file_bytes(directory / "a.bin") == first) << "the first file differs";
  EXPECT_TRUE(testing::file_bytes(directory / "b.bin") == second) << "the second file differs";
}

// tmpfs takes no direct writes on many kernels: the fallback must give the same file.
TEST(AtomicFile, FileOnTmpfsHoldsExactlyItsBytes) {
  const fs::path shm = "/dev/shm";
  if (!fs::is_directory(shm) || ::access(shm.c_str(), W_OK) != 0) GTEST_SKIP() << "no /dev/shm";
  const fs::path directory = shm / ("bondem_atomic_file_" + std::to_string(::getpid()));
  fs::remove_all(directory);
  fs::create_directories(directory);
  expect_written_whole(directory, 2 * FileWriteBuffer::kBufferBytes + 4321);
  fs::remove_all(directory);
}

TEST(AtomicFile, UncommittedFileLeavesNothingBehind) {
  const fs::path directory = scratch_directory("uncommitted");
  {
    AtomicFile file((directory / "out.bin").string());
    put_in_pieces(file.stream(), pattern(3 * FileWriteBuffer::kBufferBytes));
  }
  EXPECT_TRUE(fs::is_empty(directory));
}

// A device that is full: the failure reaches the caller (a stream in error or a failed finish),
// whether it happens in a buffer's background write or in the tail's.
TEST(AtomicFile, FailedWriteIsReported) {
  for (const std::size_t size : {std::size_t{100}, 3 * FileWriteBuffer::kBufferBytes}) {
    const int descriptor = ::open("/dev/full", O_WRONLY | O_CLOEXEC);
    if (descriptor < 0) GTEST_SKIP() << "no /dev/full";
    FileWriteBuffer buffer(descriptor);
    std::ostream out(&buffer);
    put_in_pieces(out, pattern(size));
    const bool reported = !out || !buffer.finish();
    EXPECT_TRUE(reported) << size << " bytes";
  }
}

TEST(AtomicFile, AnOfferedFileIsWrittenOverAndCutToItsNewLength) {
  // An earlier run's file offered for rewriting becomes the temporary: whatever it held, longer
  // or shorter than the new bytes, the committed file holds exactly them, and the offered name
  // is gone. Sizes above a buffer take the direct writes, below it the ordinary ones.
  const fs::path directory = scratch_directory("rewrite");
  const std::size_t buffer = FileWriteBuffer::kBufferBytes;
  for (const auto& [old_size, new_size] : std::vector<std::pair<std::size_t, std::size_t>>{
           {5 * buffer / 2 + 100, buffer + 7}, {10, 3 * buffer / 2 + 3}, {3 * buffer, 123}}) {
    const fs::path target = directory / "out.bin";
    const fs::path aside = directory / ".bondem_stale_0.tmp.1";
    { std::ofstream(aside, std::ios::binary) << std::string(old_size, 'x'); }
    offer_for_rewrite(target, aside);
    const std::string bytes = pattern(new_size);
    AtomicFile file(target.string());
    file.stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    file.commit();
    EXPECT_TRUE(testing::file_bytes(target) == bytes) << old_size << " -> " << new_size;
    EXPECT_FALSE(fs::exists(aside)) << old_size << " -> " << new_size;
  }
  // An offer nobody takes is handed back to its owner, once.
  const fs::path unused = directory / ".bondem_stale_1.tmp.1";
  offer_for_rewrite(directory / "never_written.bin", unused);
  EXPECT_EQ(withdraw_rewrites({unused}), std::vector<fs::path>{unused});
  EXPECT_TRUE(withdraw_rewrites({unused}).empty());
}

}  // namespace
}  // namespace bondem
