#pragma once
/// @file fused_pass.hpp
/// The plan of the fused pass: pass 1 run by run of rows, each run's pass 2 and drift right
/// behind it, the pairs' force records in a ring that stays in the caches (Stepper).
///
/// A particle's pass 2 needs every pair it belongs to, and its drift must wait until no row still
/// to be done reads it. Both hold once pass 1 has done the last row that holds one of its pairs.
/// A particle whose pairs all sit in rows of its own thread's share up to the end of its own run,
/// written at most a ring's length of pairs before that end, is summed and drifted right after
/// its run, from its thread's ring. The others wait for the end of pass 1 on every thread and
/// read their pairs from the PairForces arrays, into which pass 1 copies every pair of such a
/// particle: on the peer lattices the last plane, whose periodic pairs sit in the first plane's
/// rows, and the particles next to a cut between two threads' shares whose pairs sit in the other
/// share. Each sum keeps its order, so the bytes are those of the two passes.
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "solver/engine/neighbor_list.hpp"
#include "solver/engine/pair_kernel_simd.hpp"

namespace bondem {

/// The fused pass's plan for one build of the list; its cuts between threads follow the split.
struct FusedPlan {
  std::int64_t builds = -1;  ///< NeighborList::build_count() it was made for
  std::size_t particles = 0;
  bool friction = false;
  int shares = 0;
  /// Whether the pass pays: few enough particles wait for the end of pass 1.
  bool usable = false;
  std::size_t run_rows = 0;      ///< rows per run
  std::uint32_t ring_pairs = 0;  ///< pairs per ring, a power of two
  /// How far the rows holding a particle's pairs lie from it, at most, over the particles that
  /// do not always wait: the reach of a cut.
  std::size_t reach = 0;
  std::vector<std::uint8_t> waits;  ///< per particle, 1 where it waits whatever the cuts
  std::vector<std::uint64_t> bits;  ///< KeptPairs::bits: the pairs of such particles
  std::vector<std::uint32_t> rank;  ///< KeptPairs::rank
  std::uint32_t marked = 0;         ///< pairs marked in bits
  /// The particles that wait whatever the cuts, as ranges [waiting[2 r], waiting[2 r + 1]).
  std::vector<std::uint32_t> waiting;
  std::vector<std::vector<double>> ring_storage;  ///< per share
  std::vector<double> kept_records;               ///< KeptPairs::records, of every share
};

/// The cuts of one evaluation: which particles wait and which pairs each share keeps.
struct FusedCuts {
  /// The particles that wait, as ranges [ranges[2 r], ranges[2 r + 1]), sorted.
  std::vector<std::uint32_t> ranges;
  /// The ranges of pairs kept beside the marked ones, one per cut that has any: from, to and
  /// record base (KeptPairs::windows).
  std::vector<std::uint32_t> windows;
  KeptPairs kept;  ///< where the pairs are kept, for every share
};

/// Makes @p plan for @p list's current build over @p particles particles with @p friction
/// (records, else three slot arrays) for @p shares threads. It is usable when at most an eighth of
/// the particles always wait and each cut's reach spans less than an eighth of a share.
void plan_fused_pass(const NeighborList& list, std::size_t particles, bool friction, int shares,
                     FusedPlan& plan);

/// The waiting particles and kept pairs of @p plan with the shares cut at @p cuts (cuts[s] the
/// first row of share s, cuts.back() the particle count), into @p out; sizes the kept records.
void cut_fused_pass(FusedPlan& plan, const NeighborList& list, std::span<const std::size_t> cuts,
                    FusedCuts& out);

/// The ring of share @p share of @p plan, keeping pairs as @p cuts says.
FusedRing fused_ring(FusedPlan& plan, const FusedCuts& cuts, int share);

/// Particles from which the stepper takes the fused pass where it applies (the SIMD pass without
/// records or rolling resistance, a drift ahead or no output of the pairs' forces, every particle
/// counted); returns the previous count. Process-wide, for tests and benchmarks: both ways give
/// the same bytes.
std::size_t set_fused_pass_from(std::size_t particles);
/// The count set_fused_pass_from() sets (default 2^19, where the kinematics records stop).
std::size_t fused_pass_from();
/// Sets the fused pass's rows per run and smallest ring (a power of two; default 4 096 and
/// 65 536) and returns the previous pair. For tests: small shapes exercise waits and wraps.
std::pair<std::size_t, std::uint32_t> set_fused_pass_shape(std::size_t run_rows,
                                                           std::uint32_t ring_pairs);

}  // namespace bondem
