#include "io/atomic_file.hpp"

#include <unistd.h>

#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace bondem {

AtomicFile::AtomicFile(std::string path, std::ios::openmode mode)
    : path_(std::move(path)), temporary_(path_ + ".tmp." + std::to_string(::getpid())) {
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  std::error_code error;
  if (!parent.empty()) std::filesystem::create_directories(parent, error);
  if (error) throw std::runtime_error(path_ + ": cannot create directory: " + error.message());
  stream_.open(temporary_, mode | std::ios::out | std::ios::trunc);
  if (!stream_) throw std::runtime_error(path_ + ": cannot open for writing");
  stream_.precision(17);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    stream_.close();
    std::error_code ignored;
    std::filesystem::remove(temporary_, ignored);
  }
}

void AtomicFile::commit() {
  stream_.flush();
  const bool written = static_cast<bool>(stream_);
  stream_.close();
  if (!written) throw std::runtime_error(path_ + ": write failed");
  std::error_code error;
  std::filesystem::rename(temporary_, path_, error);
  if (error) throw std::runtime_error(path_ + ": cannot move into place: " + error.message());
  committed_ = true;
}

}  // namespace bondem
