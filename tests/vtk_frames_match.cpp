/// @file vtk_frames_match.cpp
/// `vtk_frames_match REFERENCE DIRECTORY`: exits 0 when the VTK series in DIRECTORY shows, frame
/// by frame, exactly what the one in REFERENCE shows, whether either writes its frames whole
/// (.vtp) or in pieces (.pvtp, read with VTK's parallel reader); otherwise prints the first
/// difference and exits 1. Particles are matched by id and contacts by their two ids, since
/// pieces hold them in another order; every value must have the same bits. Wall, tool and domain
/// files, which one process writes either way, must have the same bytes.

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "io/vtk_output.hpp"

namespace {

using bondem::VtpArray;
using bondem::VtpContents;

struct Entry {
  std::string time, file;
};

/// The (timestep, file) entries of the collection @p path, in order; none when it is missing.
std::vector<Entry> collection(const std::string& path) {
  std::ifstream in(path);
  std::vector<Entry> entries;
  static const std::regex entry(R"re(<DataSet timestep="([^"]+)"[^>]*file="([^"]+)")re");
  for (std::string line; std::getline(in, line);) {
    std::smatch match;
    if (std::regex_search(line, match, entry)) entries.push_back({match[1], match[2]});
  }
  return entries;
}

std::string bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// Item k's values: its points' coordinates, then its tuple of every array in @p arrays.
std::vector<double> item(const VtpContents& c, const std::vector<std::int64_t>& points,
                         const std::vector<VtpArray>& arrays, std::size_t k) {
  std::vector<double> values;
  for (const std::int64_t point : points) {
    const auto& p = c.points[static_cast<std::size_t>(point)];
    values.insert(values.end(), {p.x(), p.y(), p.z()});
  }
  for (const VtpArray& array : arrays) {
    const auto width = static_cast<std::size_t>(array.components);
    values.insert(values.end(), array.values.begin() + static_cast<std::ptrdiff_t>(k * width),
                  array.values.begin() + static_cast<std::ptrdiff_t>((k + 1) * width));
  }
  return values;
}

/// The items of a particle file (a point each, keyed by "id") or a contact file (a line cell
/// each, keyed by "id_i", "id_j"), sorted by key.
std::vector<std::vector<double>> sorted_items(const VtpContents& c, bool particles) {
  std::vector<std::pair<std::pair<double, double>, std::vector<double>>> items;
  if (particles) {
    const VtpArray* id = c.point_array("id");
    for (std::size_t k = 0; k < c.points.size(); ++k) {
      items.push_back(
          {{id->values[k], 0.0}, item(c, {static_cast<std::int64_t>(k)}, c.point_arrays, k)});
    }
  } else {
    const VtpArray* id_i = c.cell_array("id_i");
    const VtpArray* id_j = c.cell_array("id_j");
    for (std::size_t k = 0; k < c.lines; ++k) {
      items.push_back(
          {{id_i->values[k], id_j->values[k]}, item(c, c.cells[c.verts + k], c.cell_arrays, k)});
    }
  }
  std::sort(items.begin(), items.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::vector<double>> values;
  for (auto& [key, v] : items) values.push_back(std::move(v));
  return values;
}

/// "name:type:components" of each array, in order.
std::vector<std::string> layout(const std::vector<VtpArray>& arrays) {
  std::vector<std::string> names;
  for (const VtpArray& a : arrays) {
    names.push_back(a.name + ":" + a.type + ":" + std::to_string(a.components));
  }
  return names;
}

/// Whether two bit patterns of doubles are the same (NaN == NaN, -0 != +0).
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](double x, double y) {
           return std::memcmp(&x, &y, sizeof x) == 0;
         });
}

/// Empty when @p series of the two directories show the same frames; the difference otherwise.
std::string compare_series(const std::string& reference, const std::string& directory,
                           const std::string& series) {
  const std::vector<Entry> want = collection(reference + "/" + series + ".pvd");
  const std::vector<Entry> got = collection(directory + "/" + series + ".pvd");
  if (want.size() != got.size()) {
    return series + ".pvd: " + std::to_string(got.size()) + " frames, expected " +
           std::to_string(want.size());
  }
  const bool particles = series == "particles";
  for (std::size_t f = 0; f < want.size(); ++f) {
    const std::string where = series + " frame " + std::to_string(f) + " (" + got[f].file + ")";
    if (want[f].time != got[f].time) return where + ": time " + got[f].time + " != " + want[f].time;
    const VtpContents a = bondem::read_vtp(reference + "/" + want[f].file);
    const VtpContents b = bondem::read_vtp(directory + "/" + got[f].file);
    if (layout(a.point_arrays) != layout(b.point_arrays) ||
        layout(a.cell_arrays) != layout(b.cell_arrays)) {
      return where + ": other arrays";
    }
    if (a.points.size() != b.points.size() || a.cells.size() != b.cells.size()) {
      return where + ": " + std::to_string(b.points.size()) + " points, expected " +
             std::to_string(a.points.size());
    }
    const auto want_items = sorted_items(a, particles);
    const auto got_items = sorted_items(b, particles);
    for (std::size_t k = 0; k < want_items.size(); ++k) {
      if (!same_bits(want_items[k], got_items[k])) {
        return where + ": item " + std::to_string(k) + " (by id) differs";
      }
    }
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: vtk_frames_match REFERENCE DIRECTORY\n";
    return 2;
  }
  const std::string reference = argv[1], directory = argv[2];
  try {
    if (collection(reference + "/particles.pvd").empty()) {
      std::cerr << reference << ": no VTK series\n";
      return 1;
    }
    for (const char* series : {"particles", "contacts", "bonds"}) {
      if (const std::string difference = compare_series(reference, directory, series);
          !difference.empty()) {
        std::cerr << directory << ": " << difference << "\n";
        return 1;
      }
    }
    for (const char* series : {"walls", "tools"}) {
      const std::string pvd = std::string("/") + series + ".pvd";
      if (!std::filesystem::exists(reference + pvd)) {
        if (std::filesystem::exists(directory + pvd)) {
          std::cerr << directory << pvd << ": the reference has no such series\n";
          return 1;
        }
        continue;
      }
      const std::vector<Entry> want = collection(reference + pvd);
      if (bytes(reference + pvd) != bytes(directory + pvd)) {
        std::cerr << directory << pvd << ": differs\n";
        return 1;
      }
      for (const Entry& e : want) {
        if (bytes(reference + "/" + e.file) != bytes(directory + "/" + e.file)) {
          std::cerr << directory << "/" << e.file << ": differs\n";
          return 1;
        }
      }
    }
    if (bytes(reference + "/domain.vtp") != bytes(directory + "/domain.vtp")) {
      std::cerr << directory << "/domain.vtp: differs\n";
      return 1;
    }
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
