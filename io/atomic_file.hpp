#pragma once
/// @file atomic_file.hpp
/// Output files that appear whole or not at all: written to a temporary name, renamed on commit.

#include <fstream>
#include <string>

namespace bondem {

/// A file written under `<path>.tmp.<pid>` and renamed to `path` by commit(). If commit() is never
/// reached (an error, an exception), the destructor removes the temporary: a failing run leaves no
/// truncated output behind.
class AtomicFile {
 public:
  /// Open the temporary file; creates missing parent directories. Throws std::runtime_error.
  explicit AtomicFile(std::string path, std::ios::openmode mode = std::ios::out);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// The stream to write to.
  std::ofstream& stream() { return stream_; }
  /// Flush, close and move into place. Throws std::runtime_error if writing failed.
  void commit();

 private:
  std::string path_;
  std::string temporary_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace bondem
