#include "solver/engine/neighbor_list.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace bondem {

namespace {

/// Frees a vector's storage (clear() keeps the capacity).
template <class Vector>
void release(Vector& buffer) {
  Vector().swap(buffer);
}

/// Cells per axis of edge >= @p cell_size, at most about @p max_cells in all: unpinned axes are
/// widened alike by steps of 1.25 until the total fits; a @p pinned axis keeps three cells.
std::array<int, 3> grid_cells(const Eigen::Vector3d& length, double cell_size, double max_cells,
                              const std::array<bool, 3>& pinned) {
  std::array<int, 3> cells{};
  double width = cell_size;
  for (;;) {
    double total = 1.0;
    for (int a = 0; a < 3; ++a)
      total *= pinned[a] ? 3.0 : std::max(1.0, std::floor(length[a] / width));
    if (total <= max_cells) break;
    width *= 1.25;
  }
  for (int a = 0; a < 3; ++a) {
    cells[a] = pinned[a] ? 3 : std::max(1, static_cast<int>(std::floor(length[a] / width)));
  }
  return cells;
}

/// Strides of the linear cell index along x, y and z. Particles are sorted by cell, and every
/// parallel loop gives each thread one contiguous range of them, so the threads' ranges meet
/// across planes of the slowest axis: the data of the particles on such a plane crosses between
/// the cores' caches every step. The slowest axis is therefore the one whose cut through the
/// @p occupied cells is the smallest (twice its cross-section when the particles fill a periodic
/// axis, which is cut again where it wraps); of the other two the longer varies fastest (long
/// runs of neighbours in memory: measured 1-2 % faster on one thread than the shorter). Ties
/// keep z slowest and x fastest.
std::array<std::size_t, 3> cell_strides(const std::array<int, 3>& cells,
                                        const std::array<int, 3>& occupied,
                                        const std::array<bool, 3>& periodic) {
  const auto cut = [&](int a) {
    const double section = static_cast<double>(occupied[(a + 1) % 3]) * occupied[(a + 2) % 3];
    return periodic[a] && occupied[a] == cells[a] ? 2.0 * section : section;
  };
  int slow = 2;
  for (int a : {1, 0}) {
    if (cut(a) < cut(slow)) slow = a;
  }
  int fast = slow == 0 ? 1 : 0;
  const int other = 3 - slow - fast;
  if (occupied[other] > occupied[fast]) fast = other;
  const int middle = 3 - slow - fast;
  std::array<std::size_t, 3> stride{};
  stride[static_cast<std::size_t>(fast)] = 1;
  stride[static_cast<std::size_t>(middle)] = static_cast<std::size_t>(cells[fast]);
  stride[static_cast<std::size_t>(slow)] =
      static_cast<std::size_t>(cells[fast]) * static_cast<std::size_t>(cells[middle]);
  return stride;
}

}  // namespace

void NeighborList::bin(const Particles& p, const Domain& domain, double cell_size) {
  const std::size_t n = p.size();
  const Eigen::Vector3d length = domain.length();
  // Bound the grid to a few cells per particle: an oversized box must not cost memory.
  const double max_cells = 8.0 * static_cast<double>(n) + 1000.0;
  cells_ = grid_cells(length, cell_size, max_cells, {false, false, false});
  // Widening every axis alike can leave a periodic axis, long enough for three cells of
  // cell_size, with fewer than three (a short axis of a flat, wide domain). Keep those at three
  // and widen only the other axes; cases the first grid served keep it, and their bytes.
  std::array<bool, 3> pinned{};
  bool any_pinned = false;
  for (int a = 0; a < 3; ++a) {
    pinned[a] = domain.periodic[a] && cells_[a] < 3 && std::floor(length[a] / cell_size) >= 3.0;
    any_pinned = any_pinned || pinned[a];
  }
  if (any_pinned) cells_ = grid_cells(length, cell_size, max_cells, pinned);
  for (int a = 0; a < 3; ++a) {
    cell_width_[a] = length[a] / cells_[a];
    if (domain.periodic[a] && cells_[a] < 3) {
      std::ostringstream message;
      message << "periodic axis "
              << "xyz"[a] << " of length " << length[a]
              << " m is shorter than three neighbor cells of " << cell_size
              << " m (largest diameter + skin); enlarge the domain";
      throw std::runtime_error(message.str());
    }
  }
  const std::size_t cell_count = static_cast<std::size_t>(cells_[0]) * cells_[1] * cells_[2];
  assign_zeros(cell_of_, n);
  const double* coords[3] = {p.x.data(), p.y.data(), p.z.data()};
  bool finite = true;
  // First x fastest and z slowest, with the occupied range of each axis; then, if cell_strides
  // orders the axes otherwise, the same cells renumbered.
  int low_x = cells_[0], low_y = cells_[1], low_z = cells_[2];
  int high_x = -1, high_y = -1, high_z = -1;
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) reduction(&& : finite) \
    reduction(min : low_x, low_y, low_z) reduction(max : high_x, high_y, high_z)
  for (std::size_t i = 0; i < n; ++i) {
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const double u = (coords[a][i] - domain.min[a]) / cell_width_[a];
      finite = finite && std::isfinite(u);
      // Clamping is 1-Lipschitz in cell units, so particles outside the box still meet every
      // neighbor within one cell: the search stays exact.
      c[a] = std::isfinite(u) ? std::clamp(static_cast<int>(std::floor(u)), 0, cells_[a] - 1) : 0;
    }
    low_x = std::min(low_x, c[0]);
    low_y = std::min(low_y, c[1]);
    low_z = std::min(low_z, c[2]);
    high_x = std::max(high_x, c[0]);
    high_y = std::max(high_y, c[1]);
    high_z = std::max(high_z, c[2]);
    cell_of_[i] = static_cast<std::uint32_t>(c[0] + cells_[0] * (c[1] + cells_[1] * c[2]));
  }
  if (!finite) {
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(p.x[i]) || !std::isfinite(p.y[i]) || !std::isfinite(p.z[i])) {
        throw std::runtime_error("particle id " + std::to_string(p.id[i]) +
                                 " has a non-finite position: the run blew up (time step too "
                                 "large for the contact stiffness?)");
      }
    }
  }
  const std::array<int, 3> occupied{std::max(1, high_x - low_x + 1),
                                    std::max(1, high_y - low_y + 1),
                                    std::max(1, high_z - low_z + 1)};
  cell_stride_ = cell_strides(cells_, occupied, domain.periodic);
  const std::array<std::size_t, 3> x_fastest{1, static_cast<std::size_t>(cells_[0]),
                                             static_cast<std::size_t>(cells_[0]) * cells_[1]};
  if (cell_stride_ != x_fastest) {
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles)
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t c = cell_of_[i];
      const std::size_t x = c % x_fastest[1];
      const std::size_t y = c / x_fastest[1] % static_cast<std::size_t>(cells_[1]);
      const std::size_t z = c / x_fastest[2];
      cell_of_[i] = static_cast<std::uint32_t>(x * cell_stride_[0] + y * cell_stride_[1] +
                                               z * cell_stride_[2]);
    }
  }
  // count -> scan -> fill; the serial fill keeps each cell's particles in index order.
  assign_zeros(cell_begin_, cell_count + 1);
  for (std::size_t i = 0; i < n; ++i) ++cell_begin_[cell_of_[i] + 1];
  for (std::size_t c = 0; c < cell_count; ++c) cell_begin_[c + 1] += cell_begin_[c];
  assign_zeros(cell_items_, n);
  assign_zeros(cursor_, cell_count);
  std::copy(cell_begin_.begin(), cell_begin_.end() - 1, cursor_.begin());
  for (std::size_t i = 0; i < n; ++i)
    cell_items_[cursor_[cell_of_[i]]++] = static_cast<std::uint32_t>(i);
}

void NeighborList::bin_sorted() {
  // The positions are those bin() saw, so the grid, its strides and each cell's count stay; the
  // particles of cell c are now [cell_begin_[c], cell_begin_[c + 1]), in their old index order.
  const std::size_t cell_count = cell_begin_.size() - 1;
  for (std::size_t c = 0; c < cell_count; ++c) {
    std::fill(cell_of_.begin() + cell_begin_[c], cell_of_.begin() + cell_begin_[c + 1],
              static_cast<std::uint32_t>(c));
  }
  std::iota(cell_items_.begin(), cell_items_.end(), 0u);
}

void NeighborList::wrap_and_set_shifts(Particles& p, const Domain& domain) {
  const std::size_t n = p.size();
  const Eigen::Vector3d length = domain.length();
  for (int a = 0; a < 3; ++a) {
    if (!domain.periodic[a]) continue;
    StaggeredVector<double>& coord = a == 0 ? p.x : (a == 1 ? p.y : p.z);
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles)
    for (std::size_t i = 0; i < n; ++i) {
      coord[i] = wrap_periodic(coord[i], domain.min[a], length[a]);
    }
  }
  for (int sz = -1; sz <= 1; ++sz) {
    for (int sy = -1; sy <= 1; ++sy) {
      for (int sx = -1; sx <= 1; ++sx) {
        shifts_[image_code(sx, sy, sz)] =
            Eigen::Vector3d(sx * length.x(), sy * length.y(), sz * length.z());
      }
    }
  }
}

void NeighborList::search_row(const Particles& p, const Domain& domain,
                              const Eigen::Vector3d& length, double skin, std::size_t i,
                              StaggeredVector<std::uint32_t>& row_second,
                              StaggeredVector<std::uint8_t>& row_image) const {
  const std::size_t c = cell_of_[i];
  int home[3];
  for (int a = 0; a < 3; ++a) {
    home[a] = static_cast<int>(c / cell_stride_[static_cast<std::size_t>(a)] %
                               static_cast<std::size_t>(cells_[static_cast<std::size_t>(a)]));
  }
  // The pairs of i with the particles of @p cell, seen through the periodic image @p shift.
  const auto scan = [&](std::size_t cell, const double(&shift)[3], std::uint8_t code) {
    for (std::uint32_t k = cell_begin_[cell]; k < cell_begin_[cell + 1]; ++k) {
      const std::uint32_t j = cell_items_[k];
      if (p.id[j] <= p.id[i]) continue;
      const double d[3] = {p.x[j] - p.x[i] + shift[0], p.y[j] - p.y[i] + shift[1],
                           p.z[j] - p.z[i] + shift[2]};
      const double reach = p.radius[i] + p.radius[j] + skin;
      if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach) {
        row_second.push_back(j);
        row_image.push_back(code);
      }
    }
  };
  // A cell with neighbours on every side (most cells of a bed or a lattice): its 27 cells by
  // their index offsets, none across a periodic face, without the wrap tests per cell below (a
  // row is sorted by id afterwards, so the order of the cells does not matter): the first search
  // of a 10^6 lattice 0.165 -> 0.107 s.
  bool interior = true;
  for (int a = 0; a < 3; ++a) interior = interior && home[a] >= 1 && home[a] + 1 < cells_[a];
  if (interior) {
    const auto stride = [&](int a) {
      return static_cast<std::ptrdiff_t>(cell_stride_[static_cast<std::size_t>(a)]);
    };
    constexpr double kNoShift[3] = {0.0, 0.0, 0.0};
    for (std::ptrdiff_t dz = -1; dz <= 1; ++dz) {
      for (std::ptrdiff_t dy = -1; dy <= 1; ++dy) {
        for (std::ptrdiff_t dx = -1; dx <= 1; ++dx) {
          scan(static_cast<std::size_t>(static_cast<std::ptrdiff_t>(c) + dx * stride(0) +
                                        dy * stride(1) + dz * stride(2)),
               kNoShift, kUnshiftedImage);
        }
      }
    }
    return;
  }
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int offset[3] = {dx, dy, dz};
        int neighbor[3];
        // Image of the cell's particles seen from i: a cell reached across a periodic face
        // holds particles one period away. Periodic axes have at least three cells, wider
        // than the reach, so this is the one image that can be within reach.
        int s[3] = {0, 0, 0};
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
          neighbor[a] = home[a] + offset[a];
          if (domain.periodic[a]) {
            if (neighbor[a] < 0) {  // wrapped to the top cell: its particles one period down
              neighbor[a] += cells_[a];
              s[a] = -1;
            } else if (neighbor[a] >= cells_[a]) {  // to the bottom cell: one period up
              neighbor[a] -= cells_[a];
              s[a] = 1;
            }
          } else if (neighbor[a] < 0 || neighbor[a] >= cells_[a]) {
            inside = false;
          }
        }
        // With one or two cells on a non-periodic axis the offsets -1 and +1 are skipped or
        // distinct; with three or more periodic cells they are distinct too: no duplicates.
        if (!inside) continue;
        const double shift[3] = {s[0] * length[0], s[1] * length[1], s[2] * length[2]};
        scan(static_cast<std::size_t>(neighbor[0]) * cell_stride_[0] +
                 static_cast<std::size_t>(neighbor[1]) * cell_stride_[1] +
                 static_cast<std::size_t>(neighbor[2]) * cell_stride_[2],
             shift, image_code(s[0], s[1], s[2]));
      }
    }
  }
}

namespace {

/// Sorts a row's pairs [@p first, @p second.size()) by the id of their second particle (insertion
/// sort: a row holds a few pairs), carrying each pair's image code along.
void sort_row_by_id(const Particles& p, std::size_t first, StaggeredVector<std::uint32_t>& second,
                    StaggeredVector<std::uint8_t>& image) {
  for (std::size_t a = first + 1; a < second.size(); ++a) {
    const std::uint32_t j = second[a];
    const std::uint8_t code = image[a];
    std::size_t b = a;
    for (; b > first && p.id[second[b - 1]] > p.id[j]; --b) {
      second[b] = second[b - 1];
      image[b] = image[b - 1];
    }
    second[b] = j;
    image[b] = code;
  }
}

}  // namespace

void NeighborList::find_rows(const Particles& p, const Domain& domain, double skin) {
  const std::size_t n = p.size();
  const Eigen::Vector3d length = domain.length();
  // Rows are built per particle in parallel into per-thread buffers, then concatenated in
  // particle order: the list is the same for any number of threads. Each thread's buffers sit in
  // a cache line of their own: with the vectors' headers side by side, every push_back of one
  // thread invalidated the other's line, and two threads built the list 2-3 times slower than one.
  struct alignas(64) ThreadRows {
    StaggeredVector<std::uint32_t> second;
    StaggeredVector<std::uint8_t> image;
    std::size_t first_row = 0;  ///< the first row it searched; n: none
  };
  const int threads = threads_in_use(n);
  std::vector<ThreadRows> rows(static_cast<std::size_t>(threads));
  // Room for the rows up front, from the last build's pairs per particle (8 at the first build):
  // grown by doubling, the buffers of a 10^6 list were copied and faulted in about twice over.
  // Capacity nobody writes is address space only, never resident.
  const std::size_t previous_rows = row_begin_.empty() ? 0 : row_begin_.size() - 1;
  const double per_row =
      previous_rows > 0 ? static_cast<double>(second_.size()) / static_cast<double>(previous_rows)
                        : 8.0;
  const auto reserved = static_cast<std::size_t>(
      (1.25 * per_row + 1.0) * static_cast<double>(n / static_cast<std::size_t>(threads) + 1));
  row_begin_.resize(n + 1);
  row_begin_[0] = 0;
#pragma omp parallel num_threads(threads) if (threads > 1)
  {
    ThreadRows& mine = rows[static_cast<std::size_t>(omp_get_thread_num())];
    mine.first_row = n;
    mine.second.reserve(reserved);
    mine.image.reserve(reserved);
#pragma omp for schedule(static)
    for (std::size_t i = 0; i < n; ++i) {
      if (mine.first_row == n) mine.first_row = i;
      const std::size_t before = mine.second.size();
      search_row(p, domain, length, skin, i, mine.second, mine.image);
      sort_row_by_id(p, before, mine.second, mine.image);
      row_begin_[i + 1] = static_cast<std::uint32_t>(mine.second.size() - before);
    }
  }
  for (std::size_t i = 0; i < n; ++i) row_begin_[i + 1] += row_begin_[i];
  // Sized with pages mapped on every thread, then each thread copies its own rows in place.
  assign_zeros(second_, row_begin_[n]);
  assign_zeros(image_, row_begin_[n]);
#pragma omp parallel for schedule(static, 1) num_threads(threads) if (threads > 1)
  for (std::size_t t = 0; t < rows.size(); ++t) {
    if (rows[t].first_row == n) continue;
    std::copy(rows[t].second.begin(), rows[t].second.end(),
              second_.begin() + row_begin_[rows[t].first_row]);
    std::copy(rows[t].image.begin(), rows[t].image.end(),
              image_.begin() + row_begin_[rows[t].first_row]);
  }
}

void NeighborList::index_columns(const Particles& p) {
  const std::size_t n = row_begin_.size() - 1;
  // Transposed index, count -> scan -> fill in pair order.
  assign_zeros(column_begin_, n + 1);
  for (const std::uint32_t j : second_) ++column_begin_[j + 1];
  for (std::size_t i = 0; i < n; ++i) column_begin_[i + 1] += column_begin_[i];
  assign_zeros(column_pair_, second_.size());
  assign_zeros(cursor_, n);
  std::copy(column_begin_.begin(), column_begin_.end() - 1, cursor_.begin());
  // The first particle of each entry, kept while sorting: columns sort by its id.
  StaggeredVector<std::uint32_t> first_of;
  assign_zeros(first_of, second_.size());
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = row_begin_[i]; k < row_begin_[i + 1]; ++k) {
      const std::uint32_t slot = cursor_[second_[k]]++;
      column_pair_[slot] = k;
      first_of[slot] = static_cast<std::uint32_t>(i);
    }
  }
  // Each column by the id of the pair's first particle (insertion sort: a column holds a few
  // pairs), so that a particle's partners come in id order whatever the storage order.
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles)
  for (std::size_t j = 0; j < n; ++j) {
    for (std::uint32_t a = column_begin_[j] + 1; a < column_begin_[j + 1]; ++a) {
      const std::uint32_t pair = column_pair_[a];
      const std::uint32_t first = first_of[a];
      std::uint32_t b = a;
      for (; b > column_begin_[j] && p.id[first_of[b - 1]] > p.id[first]; --b) {
        column_pair_[b] = column_pair_[b - 1];
        first_of[b] = first_of[b - 1];
      }
      column_pair_[b] = pair;
      first_of[b] = first;
    }
  }
}

void NeighborList::release_scratch() {
  // The grid serves only while building (find_rows frees its per-thread buffers itself). Returning
  // it keeps what a run holds between rebuilds to the list itself (about 30 bytes per particle
  // less, with those buffers); a rebuild, every tens of steps at most, pays a few allocations.
  release(cell_of_);
  release(cell_begin_);
  release(cell_items_);
  release(cursor_);
}

void NeighborList::build(Particles& p, const Domain& domain, double skin, bool reorder) {
  const std::size_t n = p.size();
  wrap_and_set_shifts(p, domain);
  double max_radius = 0.0;
  for (std::size_t i = 0; i < n; ++i) max_radius = std::max(max_radius, p.radius[i]);
  const double cell_size = std::max(2.0 * max_radius + skin, 1e-300);

  bin(p, domain, cell_size);
  if (reorder) {
    p.permute(cell_items_);  // particles sorted by cell: neighbors become neighbors in memory
    bin_sorted();
  }
  find_rows(p, domain, skin);
  index_columns(p);

  x0_ = p.x;
  y0_ = p.y;
  z0_ = p.z;
  ++builds_;
  release_scratch();
}

void NeighborList::save(NeighborListState& state) const {
  state.builds = builds_;
  state.x0 = x0_;
  state.y0 = y0_;
  state.z0 = z0_;
}

void NeighborList::restore(Particles& p, const Domain& domain, double skin,
                           const NeighborListState& state) {
  if (state.x0.size() != p.size()) {
    throw std::runtime_error("neighbor-list state does not match the particle count");
  }
  // The list is a function of the build positions alone: rebuild from them, then put the
  // current positions back. Wrapping already-wrapped coordinates leaves them unchanged.
  StaggeredVector<double> x = state.x0, y = state.y0, z = state.z0;
  p.x.swap(x);
  p.y.swap(y);
  p.z.swap(z);
  build(p, domain, skin, false);
  p.x.swap(x);
  p.y.swap(y);
  p.z.swap(z);
  builds_ = state.builds;
}

}  // namespace bondem
