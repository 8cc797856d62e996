#pragma once
/// @file decomposition.hpp
/// Recursive coordinate bisection of a domain into subdomains of equal measured cost: where each
/// rank of a distributed run owns its particles.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "geometry/box.hpp"
#include "geometry/domain.hpp"

namespace bondem {

/// A cut of the bisection tree: points with coordinate[axis] < position go to the low side.
struct BisectionCut {
  int axis = 0;
  double position = 0.0;
  int low = -1;   ///< child node of the low side
  int high = -1;  ///< child node of the high side
  int rank = -1;  ///< a leaf's rank (then axis, position, low and high are unused)
};

/// Collective reductions over the processes that share a spread bisection: each process calls
/// them alike, with as many values, and every process receives the same results, elementwise.
struct SpreadReductions {
  std::function<void(std::span<double> values)> sum;  ///< replaced by their sums
  std::function<void(std::span<double> values)> max;  ///< replaced by their maximums
};

/// The subdomains of a bisection: a tree of cuts whose leaves are the ranks, in depth-first
/// order (low side first). Every point of space has exactly one owner: the subdomains at the
/// domain's faces extend beyond them, so particles slightly outside still belong somewhere.
class Decomposition {
 public:
  /// Rank that owns point (@p x, @p y, @p z).
  int owner(double x, double y, double z) const;
  /// The part of @p domain that rank @p rank owns.
  Box box(int rank, const Box& domain) const;
  /// Number of subdomains.
  int ranks() const { return ranks_; }
  /// The cuts, root first.
  const std::vector<BisectionCut>& cuts() const { return nodes_; }

 private:
  friend Decomposition bisect(std::span<const double>, std::span<const double>,
                              std::span<const double>, std::span<const double>,
                              std::span<const std::int64_t>, const Box&, int, double);
  friend Decomposition bisect_spread(std::span<const double>, std::span<const double>,
                                     std::span<const double>, std::span<const double>, const Box&,
                                     int, double, const SpreadReductions&);
  std::vector<BisectionCut> nodes_;
  int ranks_ = 0;
};

/// Bisects @p domain into @p ranks subdomains of about equal total @p cost (one value per
/// particle at x, y, z, for example 1 + its contacts, so that a dense heap counts for more than
/// a sparse gas). Each level cuts the longest side of the current box where the cost splits in
/// the ratio of the ranks on either side (ranks / 2 below, the rest above), between two distinct
/// coordinates, and no closer than @p min_width to the box's sides (a subdomain must be wider
/// than the halo it trades with its neighbours). Particles are taken by (coordinate, @p id), so
/// the result does not depend on their order. Throws std::invalid_argument when @p ranks < 1,
/// the arrays differ in length, or a box is narrower than two @p min_width where it must be cut.
Decomposition bisect(std::span<const double> x, std::span<const double> y,
                     std::span<const double> z, std::span<const double> cost,
                     std::span<const std::int64_t> id, const Box& domain, int ranks,
                     double min_width);

/// The particles rank @p rank needs, in index order: those it owns and those within @p halo of
/// its subdomain along every axis (periodic images included), a superset of the spheres within
/// @p halo of it. With @p halo the largest interaction distance plus twice the skin, the step of
/// every owned particle depends on these alone.
std::vector<std::uint32_t> subdomain_members(const Decomposition& decomposition, int rank,
                                             const Domain& domain, double halo,
                                             std::span<const double> x, std::span<const double> y,
                                             std::span<const double> z);

/// bisect() of particles spread over processes, none holding more than its own: each process
/// passes its particles (@p x, @p y, @p z, @p cost), and the cuts come from sums and extremes
/// across them (@p across, a few dozen reductions per cut), the same cuts as bisect() of all the
/// particles in one place. The costs must be whole numbers (below 2^53), so that their sums are
/// exact in any order. Throws std::invalid_argument as bisect() does, on every process alike.
Decomposition bisect_spread(std::span<const double> x, std::span<const double> y,
                            std::span<const double> z, std::span<const double> cost,
                            const Box& domain, int ranks, double min_width,
                            const SpreadReductions& across);

}  // namespace bondem
