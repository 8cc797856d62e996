#include "solver/parallel/decomposition.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace bondem {

namespace {

/// What bisect() works on: the particles' coordinates, costs and ids.
struct Items {
  std::array<std::span<const double>, 3> coordinate;
  std::span<const double> cost;
  std::span<const std::int64_t> id;
};

/// The longest side of @p box that can be cut into two of at least @p min_width (ties: x, then
/// y, then z). Throws std::invalid_argument when none can.
int cut_axis(const Box& box, int ranks, double min_width) {
  std::array<int, 3> axes{0, 1, 2};
  const Eigen::Vector3d side = box.max - box.min;
  std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return side[a] > side[b]; });
  const int* cuttable =
      std::find_if(axes.begin(), axes.end(), [&](int a) { return side[a] >= 2.0 * min_width; });
  if (cuttable == axes.end()) {
    throw std::invalid_argument("a subdomain of " + std::to_string(side.x()) + " x " +
                                std::to_string(side.y()) + " x " + std::to_string(side.z()) +
                                " m cannot be cut into " + std::to_string(ranks) +
                                " with sides of at least " + std::to_string(min_width) +
                                " m: too many ranks for this domain");
  }
  return *cuttable;
}

/// @p position moved so that both sides are at least @p min_width wide (as far as the box
/// allows: it is 2 min_width at least along @p axis).
double clamped_cut(double position, const Box& box, int axis, double min_width) {
  return std::clamp(position, box.min[axis] + min_width, box.max[axis] - min_width);
}

/// Builds the subtree of @p ranks subdomains, ranks first_rank.., for particles @p members
/// (indices into @p coordinate) inside @p box into @p nodes; returns its root. Each cut is on
/// cut_axis(), at @p position_of(members, axis, box, low_ranks, ranks), moved to leave both
/// sides min_width wide: the one step in which bisect() and bisect_spread() differ.
template <class PositionOf>
int build_subtree(const std::array<std::span<const double>, 3>& coordinate,
                  std::vector<std::uint32_t>& members, const Box& box, int first_rank, int ranks,
                  double min_width, std::vector<BisectionCut>& nodes, PositionOf& position_of) {
  const int node = static_cast<int>(nodes.size());
  nodes.emplace_back();
  if (ranks == 1) {
    nodes[static_cast<std::size_t>(node)].rank = first_rank;
    return node;
  }
  const int axis = cut_axis(box, ranks, min_width);
  const int low_ranks = ranks / 2;
  const double position =
      clamped_cut(position_of(members, axis, box, low_ranks, ranks), box, axis, min_width);
  const std::span<const double> c = coordinate[static_cast<std::size_t>(axis)];
  const auto split = std::partition(members.begin(), members.end(),
                                    [&](std::uint32_t i) { return c[i] < position; });
  std::vector<std::uint32_t> high(split, members.end());
  members.erase(split, members.end());
  Box low_box = box, high_box = box;
  low_box.max[axis] = position;
  high_box.min[axis] = position;
  const int low = build_subtree(coordinate, members, low_box, first_rank, low_ranks, min_width,
                                nodes, position_of);
  const int high_node = build_subtree(coordinate, high, high_box, first_rank + low_ranks,
                                      ranks - low_ranks, min_width, nodes, position_of);
  BisectionCut& cut = nodes[static_cast<std::size_t>(node)];
  cut.axis = axis;
  cut.position = position;
  cut.low = low;
  cut.high = high_node;
  return node;
}

/// bisect()'s cut of @p members along @p axis: between the two distinct coordinates whose
/// low-side cost is nearest @p low_ranks / @p ranks of the total, the first on a tie (the box's
/// middle when there are no two distinct coordinates).
double cut_position(const Items& items, std::vector<std::uint32_t>& members, int axis,
                    const Box& box, int low_ranks, int ranks) {
  const std::span<const double> coordinate = items.coordinate[static_cast<std::size_t>(axis)];
  std::sort(members.begin(), members.end(), [&](std::uint32_t a, std::uint32_t b) {
    return coordinate[a] != coordinate[b] ? coordinate[a] < coordinate[b]
                                          : items.id[a] < items.id[b];
  });
  double total = 0.0;
  for (const std::uint32_t i : members) total += items.cost[i];
  const double target = total * low_ranks / ranks;
  const std::size_t n = members.size();
  std::size_t best = n;
  double best_miss = std::numeric_limits<double>::infinity();
  double below = 0.0;
  for (std::size_t b = 1; b < n; ++b) {
    below += items.cost[members[b - 1]];
    if (!(coordinate[members[b - 1]] < coordinate[members[b]])) continue;
    const double miss = std::abs(below - target);
    if (miss < best_miss) {
      best_miss = miss;
      best = b;
    }
  }
  return best < n ? 0.5 * (coordinate[members[best - 1]] + coordinate[members[best]])
                  : 0.5 * (box.min[axis] + box.max[axis]);
}

/// @p value as an unsigned key in the order of the doubles (a negative one's bits inverted, the
/// sign bit of the others set), so that a bisection over keys searches the doubles.
std::uint64_t ordered_key(double value) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof bits);
  constexpr std::uint64_t kSign = std::uint64_t{1} << 63;
  return (bits & kSign) != 0 ? ~bits : bits | kSign;
}

/// The double of ordered_key() @p key.
double from_ordered_key(std::uint64_t key) {
  constexpr std::uint64_t kSign = std::uint64_t{1} << 63;
  const std::uint64_t bits = (key & kSign) != 0 ? key & ~kSign : ~key;
  double value = 0.0;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

}  // namespace

/// bisect()'s cut position found from reductions across the processes, each holding some of the
/// particles: built alike on every process.
struct SpreadCut {
  std::array<std::span<const double>, 3> coordinate;
  std::span<const double> cost;
  const SpreadReductions& across;

  /// The cut of the node's particles, this process's @p members of them, along @p axis.
  double operator()(const std::vector<std::uint32_t>& members, int axis, const Box& box,
                    int low_ranks, int ranks) const {
    const std::span<const double> c = coordinate[static_cast<std::size_t>(axis)];
    constexpr double kNone = -std::numeric_limits<double>::infinity();
    double totals[2] = {0.0, 0.0};        // particles, cost
    double extremes[2] = {kNone, kNone};  // the largest coordinate, and minus the smallest
    for (const std::uint32_t i : members) {
      totals[0] += 1.0;
      totals[1] += cost[i];
      extremes[0] = std::max(extremes[0], c[i]);
      extremes[1] = std::max(extremes[1], -c[i]);
    }
    across.sum(totals);
    across.max(extremes);
    const double target = totals[1] * low_ranks / ranks;
    const double lowest = -extremes[1];
    const double highest = extremes[0];
    double position = 0.5 * (box.min[axis] + box.max[axis]);  // no two distinct coordinates
    if (totals[0] >= 2.0 && lowest < highest) {
      // The cost at coordinates up to t only grows with t; a: the smallest coordinate at which
      // it reaches the target (it does at the highest, where it is the total).
      std::uint64_t low_key = ordered_key(lowest);
      std::uint64_t high_key = ordered_key(highest);
      while (low_key < high_key) {
        const std::uint64_t middle = low_key + (high_key - low_key) / 2;
        const double t = from_ordered_key(middle);
        double up_to = 0.0;
        for (const std::uint32_t i : members) up_to += c[i] <= t ? cost[i] : 0.0;
        across.sum(std::span(&up_to, 1));
        if (up_to >= target) {
          high_key = middle;
        } else {
          low_key = middle + 1;
        }
      }
      const double a = from_ordered_key(low_key);
      // bisect()'s best split lies next to a: between a and the coordinate below it (the cost
      // below a, short of the target) or between a and the one above (the cost up to a). A split
      // further off misses the target by more, as every cost is positive; a tie goes low.
      double below[2] = {0.0, 0.0};       // the cost below a, and up to a
      double around[2] = {kNone, kNone};  // the coordinate below a, and minus the one above
      for (const std::uint32_t i : members) {
        if (c[i] < a) {
          below[0] += cost[i];
          around[0] = std::max(around[0], c[i]);
        } else if (c[i] > a) {
          around[1] = std::max(around[1], -c[i]);
        }
        below[1] += c[i] <= a ? cost[i] : 0.0;
      }
      across.sum(below);
      across.max(around);
      const bool has_lower = around[0] != kNone;
      const bool has_higher = around[1] != kNone;
      if (has_lower) position = 0.5 * (around[0] + a);
      if (has_higher && (!has_lower || std::abs(below[1] - target) < std::abs(below[0] - target))) {
        position = 0.5 * (a - around[1]);
      }
    }
    return position;
  }
};

Decomposition bisect_spread(std::span<const double> x, std::span<const double> y,
                            std::span<const double> z, std::span<const double> cost,
                            const Box& domain, int ranks, double min_width,
                            const SpreadReductions& across) {
  if (ranks < 1) throw std::invalid_argument("bisect: ranks must be at least 1");
  const std::size_t n = x.size();
  if (y.size() != n || z.size() != n || cost.size() != n) {
    throw std::invalid_argument("bisect: coordinates and costs differ in length");
  }
  Decomposition d;
  d.ranks_ = ranks;
  std::vector<std::uint32_t> members(n);
  std::iota(members.begin(), members.end(), std::uint32_t{0});
  SpreadCut position_of{{x, y, z}, cost, across};
  build_subtree({x, y, z}, members, domain, 0, ranks, min_width, d.nodes_, position_of);
  return d;
}

int Decomposition::owner(double x, double y, double z) const {
  const double point[3] = {x, y, z};
  std::size_t node = 0;
  while (nodes_[node].rank < 0) {
    const BisectionCut& cut = nodes_[node];
    node = static_cast<std::size_t>(point[cut.axis] < cut.position ? cut.low : cut.high);
  }
  return nodes_[node].rank;
}

Box Decomposition::box(int rank, const Box& domain) const {
  Box result = domain;
  std::size_t node = 0;
  while (nodes_[node].rank < 0) {
    const BisectionCut& cut = nodes_[node];
    // Leaves are numbered depth-first, low side first: the high side's ranks start at the
    // leaf reached from it by always going low.
    std::size_t first_high = static_cast<std::size_t>(cut.high);
    while (nodes_[first_high].rank < 0) {
      first_high = static_cast<std::size_t>(nodes_[first_high].low);
    }
    if (rank < nodes_[first_high].rank) {
      result.max[cut.axis] = cut.position;
      node = static_cast<std::size_t>(cut.low);
    } else {
      result.min[cut.axis] = cut.position;
      node = static_cast<std::size_t>(cut.high);
    }
  }
  return result;
}

std::vector<std::uint32_t> subdomain_members(const Decomposition& decomposition, int rank,
                                             const Domain& domain, double halo,
                                             std::span<const double> x, std::span<const double> y,
                                             std::span<const double> z) {
  const Box box = decomposition.box(rank, Box{domain.min, domain.max});
  const Eigen::Vector3d length = domain.length();
  std::vector<std::uint32_t> members;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double point[3] = {x[i], y[i], z[i]};
    bool near = true;
    if (decomposition.owner(point[0], point[1], point[2]) != rank) {
      // The gap to the box along each axis, from the nearest periodic image.
      for (int a = 0; a < 3 && near; ++a) {
        double gap = std::numeric_limits<double>::infinity();
        for (const double shift : {-length[a], 0.0, length[a]}) {
          if (shift != 0.0 && !domain.periodic[static_cast<std::size_t>(a)]) continue;
          const double u = point[a] + shift;
          gap = std::min(gap, std::max({box.min[a] - u, u - box.max[a], 0.0}));
        }
        near = gap < halo;
      }
    }
    if (near) members.push_back(static_cast<std::uint32_t>(i));
  }
  return members;
}

Decomposition bisect(std::span<const double> x, std::span<const double> y,
                     std::span<const double> z, std::span<const double> cost,
                     std::span<const std::int64_t> id, const Box& domain, int ranks,
                     double min_width) {
  if (ranks < 1) throw std::invalid_argument("bisect: ranks must be at least 1");
  const std::size_t n = x.size();
  if (y.size() != n || z.size() != n || cost.size() != n || id.size() != n) {
    throw std::invalid_argument("bisect: coordinates, costs and ids differ in length");
  }
  Items items{{x, y, z}, cost, id};
  std::vector<std::uint32_t> members(n);
  std::iota(members.begin(), members.end(), std::uint32_t{0});
  Decomposition d;
  d.ranks_ = ranks;
  const auto position_of = [&](std::vector<std::uint32_t>& node_members, int axis, const Box& box,
                               int low_ranks, int node_ranks) {
    return cut_position(items, node_members, axis, box, low_ranks, node_ranks);
  };
  build_subtree(items.coordinate, members, domain, 0, ranks, min_width, d.nodes_, position_of);
  return d;
}

}  // namespace bondem
