#pragma once
// File and run helpers shared by the tests that run whole cases.
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/run.hpp"
#include "solver/engine/particles.hpp"

namespace bondem::testing {

/// The whole content of the file at @p path, byte for byte ("" if it cannot be read).
inline std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// Where tests write: `tmp/` in the build tree (BONDEM_TEST_TMPDIR), so that two build trees
/// testing at once on one machine never share a directory.
inline std::filesystem::path test_root() {
  const std::filesystem::path root(BONDEM_TEST_TMPDIR);
  std::filesystem::create_directories(root);
  return root;
}

/// An empty output directory bondem_<name> under test_root(); names must be unique across test
/// files, which ctest runs in parallel.
inline std::filesystem::path fresh_directory(const std::string& name) {
  const std::filesystem::path directory = test_root() / ("bondem_" + name);
  std::filesystem::remove_all(directory);
  return directory;
}

/// Whether the bytes of @p a and @p b are equal (-0.0 and 0.0, or two NaNs, are told apart).
inline bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

/// Whether particle @p k of @p p has the position, velocity and spin of particle @p i of @p q,
/// bit for bit.
inline bool same_motion(const Particles& p, std::size_t k, const Particles& q, std::size_t i) {
  return same_bits(p.x[k], q.x[i]) && same_bits(p.y[k], q.y[i]) && same_bits(p.z[k], q.z[i]) &&
         same_bits(p.vx[k], q.vx[i]) && same_bits(p.vy[k], q.vy[i]) &&
         same_bits(p.vz[k], q.vz[i]) && same_bits(p.wx[k], q.wx[i]) &&
         same_bits(p.wy[k], q.wy[i]) && same_bits(p.wz[k], q.wz[i]);
}

/// run_case into @p directory without progress output, optionally from a checkpoint and with a
/// stop flag.
inline RunResult quiet_run(const Case& c, const std::filesystem::path& directory,
                           const std::string& restart = "",
                           const volatile std::sig_atomic_t* stop = nullptr) {
  RunOptions options;
  options.output_directory = directory.string();
  options.quiet = true;
  options.restart_path = restart;
  options.stop_requested = stop;
  std::ostringstream log;
  return run_case(c, options, log);
}

/// A CSV file with a header line: its column names and its rows, as text fields.
struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  /// Index of column @p name; throws std::out_of_range when there is none.
  std::size_t column(const std::string& name) const {
    for (std::size_t k = 0; k < header.size(); ++k) {
      if (header[k] == name) return k;
    }
    throw std::out_of_range("no column " + name);
  }
  /// Field @p name of row @p row as a number.
  double number(std::size_t row, const std::string& name) const {
    return std::stod(rows.at(row).at(column(name)));
  }
};

/// The CSV file at @p path (fields split at commas; no quoting).
inline CsvTable read_csv(const std::filesystem::path& path) {
  std::istringstream in(file_bytes(path));
  const auto fields = [](const std::string& line) {
    std::vector<std::string> out;
    std::istringstream row(line);
    for (std::string field; std::getline(row, field, ',');) out.push_back(field);
    return out;
  };
  CsvTable table;
  std::string line;
  if (std::getline(in, line)) table.header = fields(line);
  while (std::getline(in, line)) table.rows.push_back(fields(line));
  return table;
}

}  // namespace bondem::testing
