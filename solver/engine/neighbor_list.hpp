#pragma once
/// @file neighbor_list.hpp
/// Verlet neighbor list on a uniform cell grid (spatial hashing), built count -> scan -> fill.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "geometry/domain.hpp"
#include "solver/engine/particles.hpp"
#include "solver/engine/staggered_vector.hpp"

namespace bondem {

/// What a neighbor list needs to be rebuilt exactly as it was: the positions of its last build.
struct NeighborListState {
  std::int64_t builds = 0;
  StaggeredVector<double> x0, y0, z0;
};

/// Image code of the periodic image shifted by (@p sx, @p sy, @p sz) boxes, each -1, 0 or 1.
constexpr std::uint8_t image_code(int sx, int sy, int sz) {
  return static_cast<std::uint8_t>((sx + 1) + 3 * (sy + 1) + 9 * (sz + 1));
}

/// Image code of a pair that sees j itself (a zero shift): most pairs.
inline constexpr std::uint8_t kUnshiftedImage = image_code(0, 0, 0);

/// Half neighbor list in compressed rows: row i lists the particles j of larger id than i whose
/// surfaces were closer than the skin at the last build, by id, each with the periodic image of j
/// to use. A transposed index lists, for every particle j, the pairs in which it is the second
/// member, by the id of the first. Every pair is thus seen from its smaller id and every
/// particle's pairs come in id order whatever the order the particles are stored in: the forces
/// are the same bytes after any reordering (and, later, on any domain decomposition).
class NeighborList {
 public:
  /// Rebuild for the current positions. Wraps periodic coordinates into the domain and, when
  /// @p reorder is set, first sorts all particle arrays by cell for cache locality.
  /// Throws std::runtime_error on a non-finite position or a periodic axis too short for the grid.
  void build(Particles& p, const Domain& domain, double skin, bool reorder);

  /// Save the positions of the last build and the build count.
  void save(NeighborListState& state) const;

  /// Positions of the last build along @p axis (0, 1, 2: what save() copies), for a writer that
  /// streams them instead and for the stepper's displacement check (opening_sweep).
  const StaggeredVector<double>& build_positions(int axis) const {
    return axis == 0 ? x0_ : axis == 1 ? y0_ : z0_;
  }

  /// Rebuild the list of a saved state for particles in the same order (no reordering).
  void restore(Particles& p, const Domain& domain, double skin, const NeighborListState& state);

  /// Number of candidate pairs.
  std::size_t pair_count() const { return second_.size(); }

  /// Number of rows: the particle count at the last build.
  std::size_t row_count() const { return row_begin_.empty() ? 0 : row_begin_.size() - 1; }

  /// Calls @p visit(i, j, k) for every pair in list order (rows by i, then k), serially; k
  /// indexes the per-pair arrays. A visitor that returns bool stops the walk by returning false.
  template <class Visit>
  void for_each_pair(Visit&& visit) const {
    const std::size_t rows = row_count();
    for (std::size_t i = 0; i < rows; ++i) {
      for (std::uint32_t k = row_begin_[i]; k < row_begin_[i + 1]; ++k) {
        const std::size_t j = second_[k];
        if constexpr (std::is_same_v<
                          std::invoke_result_t<Visit&, std::size_t, std::size_t, std::uint32_t>,
                          bool>) {
          if (!visit(i, j, k)) return;
        } else {
          visit(i, j, k);
        }
      }
    }
  }

  /// The pairs of rows [@p first_row, @p last_row) in list order, in blocks of up to kBlock
  /// consecutive pairs: @p prepare(s, i, j, k) for every pair of a block, then @p evaluate(s, i,
  /// j, k) for every pair of the same block; s is the pair's place in its block. Two short loops
  /// instead of one long body let the independent latencies of the first (square roots,
  /// divisions) overlap in the pipeline. Serial: the caller splits rows among threads.
  template <std::uint32_t kBlock, class Prepare, class Evaluate>
  [[gnu::always_inline]] void for_each_pair_block(std::size_t first_row, std::size_t last_row,
                                                  Prepare&& prepare, Evaluate&& evaluate) const {
    std::uint32_t first_of[kBlock];
    std::size_t row = first_row;
    const std::uint32_t pairs_end = row_begin_[last_row];
    for (std::uint32_t block = row_begin_[first_row]; block < pairs_end; block += kBlock) {
      const std::uint32_t block_end = std::min(pairs_end, block + kBlock);
      for (std::uint32_t k = block; k < block_end; ++k) {
        while (row_begin_[row + 1] <= k) ++row;
        first_of[k - block] = static_cast<std::uint32_t>(row);
        prepare(k - block, row, std::size_t{second_[k]}, k);
      }
      for (std::uint32_t k = block; k < block_end; ++k) {
        evaluate(k - block, std::size_t{first_of[k - block]}, std::size_t{second_[k]}, k);
      }
    }
  }

  /// First pair of each row, size row_count() + 1: row i holds pairs [row_begins()[i],
  /// row_begins()[i + 1]). For kernels that walk the list themselves (pair_kernel_simd.cpp).
  const StaggeredVector<std::uint32_t>& row_begins() const { return row_begin_; }

  /// Second particle j of pair k.
  std::size_t second(std::uint32_t k) const { return second_[k]; }

  /// Image code of pair k: separation() adds shift_table()[image(k)].
  std::uint8_t image(std::uint32_t k) const { return image_[k]; }

  /// Every pair's second particle and image code, in pair order (kernels that walk the list).
  const std::uint32_t* seconds() const { return second_.data(); }
  const std::uint8_t* images() const { return image_.data(); }  ///< see seconds()

  /// The periodic shifts by image code.
  const std::array<Eigen::Vector3d, 27>& shift_table() const { return shifts_; }

  /// The pairs of particle @p i: @p as_first(k) for each pair in which it is the first member,
  /// then @p as_second(k) for each in which it is the second, each by the partner's id. Serial;
  /// one fixed order per particle, so sums over it are the same bytes for any thread count and
  /// any storage order.
  template <class AsFirst, class AsSecond>
  [[gnu::always_inline]] void for_each_pair_of(std::size_t i, AsFirst&& as_first,
                                               AsSecond&& as_second) const {
    for (std::uint32_t k = row_begin_[i]; k < row_begin_[i + 1]; ++k) as_first(k);
    for (std::uint32_t c = column_begin_[i]; c < column_begin_[i + 1]; ++c) {
      as_second(column_pair_[c]);
    }
  }

  /// x_j - x_i of pair k, with the periodic image of j that the list sees from i.
  Eigen::Vector3d separation(const Particles& p, std::size_t i, std::size_t j,
                             std::uint32_t k) const {
    const Eigen::Vector3d& s = shifts_[image_[k]];
    return {p.x[j] - p.x[i] + s.x(), p.y[j] - p.y[i] + s.y(), p.z[j] - p.z[i] + s.z()};
  }

  /// Offset to add to x_j - x_i for pair k (its periodic image of j).
  const Eigen::Vector3d& shift(std::uint32_t k) const { return shifts_[image_[k]]; }

  /// Number of builds so far (restored ones included).
  std::int64_t build_count() const { return builds_; }

 private:
  /// Wrap periodic coordinates into the domain and fill the image shift table.
  void wrap_and_set_shifts(Particles& p, const Domain& domain);
  void bin(const Particles& p, const Domain& domain, double cell_size);
  /// What bin() gives once the particles are permuted by cell_items_: the same grid, each cell's
  /// particles consecutive in index order, without binning them again.
  void bin_sorted();
  /// Append particle i's row (pairs with j of larger id within reach, each with its image code),
  /// in search order.
  void search_row(const Particles& p, const Domain& domain, const Eigen::Vector3d& length,
                  double skin, std::size_t i, StaggeredVector<std::uint32_t>& row_second,
                  StaggeredVector<std::uint8_t>& row_image) const;
  /// All rows, searched in parallel into per-thread buffers and concatenated in particle order.
  void find_rows(const Particles& p, const Domain& domain, double skin);
  /// The transposed index (pairs by their second particle), count -> scan -> fill, each
  /// particle's pairs sorted by the id of their first particle.
  void index_columns(const Particles& p);
  /// Return the grid, which serves only while building.
  void release_scratch();

  StaggeredVector<std::uint32_t>
      row_begin_;  ///< size n + 1: pairs of particle i are [row_begin_[i], row_begin_[i+1])
  StaggeredVector<std::uint32_t> second_;  ///< j of each pair
  StaggeredVector<std::uint8_t> image_;    ///< index into shifts_: periodic image of j seen from i
  StaggeredVector<std::uint32_t> column_begin_;  ///< size n + 1: transposed rows
  StaggeredVector<std::uint32_t> column_pair_;   ///< pair indices in which particle j is second
  std::array<Eigen::Vector3d, 27> shifts_;       ///< add to x_j - x_i for image code k
  std::int64_t builds_ = 0;                      ///< number of builds so far
  std::array<int, 3> cells_{1, 1, 1};
  std::array<std::size_t, 3> cell_stride_{1, 1, 1};  ///< of the linear cell index (cell_strides)
  Eigen::Vector3d cell_width_ = Eigen::Vector3d::Ones();
  StaggeredVector<double> x0_, y0_, z0_;  ///< positions at the last build
  // Scratch space of build(), released when it returns.
  // Staggered: their pages are first written on every thread (assign_zeros) and, at 10^6
  // particles, huge pages.
  StaggeredVector<std::uint32_t> cell_of_;     ///< cell of each particle
  StaggeredVector<std::uint32_t> cell_begin_;  ///< size cells + 1
  StaggeredVector<std::uint32_t> cell_items_;  ///< particles sorted by cell, by index within a cell
  StaggeredVector<std::uint32_t> cursor_;
};

}  // namespace bondem
