#pragma once
/// @file fused_pair_passes.hpp
/// Pass 1 in SIMD lanes with pass 2 gathering each block of particles right behind it.
///
/// Pass 2 of a particle needs the records of its own row and of the rows before it (a pair's
/// first particle has the smaller index). Each thread therefore gathers a block of its share as
/// soon as its own pass 1 has evaluated the block's rows, while the records it reads are still
/// in cache; run one after the other, pass 2 found most of them evicted by the rest of pass 1.
/// A block with a transposed pair in an earlier share's rows waits for the end of pass 1 and is
/// gathered in a second parallel region. Every particle's sum keeps its order (ForceGather), so
/// the bytes are those of the two passes run one after the other, whatever the thread count.

#include <omp.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "solver/engine/contact_kernel.hpp"
#include "solver/engine/pair_kernel_simd.hpp"

namespace bondem {

/// Particles from which a run fuses the passes (Stepper::fuse_pair_passes_from). Below it the
/// records stay in cache from pass 1 to pass 2 and fusing cost time: the 20 800 peer lattice ran
/// 1-3 % slower on one thread and 3.5 % on two (deferred blocks leave one thread idle at the
/// end); the 998 400 lattice ran 7 % faster on two threads (three alternating rounds).
inline constexpr std::size_t kFusedPassParticles = 32768;

/// What the fused passes keep across steps: each share's progress and its deferred blocks.
struct FusedPassState {
  /// A block whose transposed pairs end at @p transposed_end, beyond what pass 1 evaluated.
  struct Waiting {
    std::size_t block;
    std::uint32_t transposed_end;
  };
  struct Share {
    std::size_t next_block = 0;         ///< first block of the share not yet gathered or deferred
    std::size_t end_block = 0;          ///< the share's end
    std::uint32_t first_pair = 0;       ///< the share's first pair: smaller ones are other shares'
    std::vector<Waiting> waiting;       ///< blocks waiting for a later row of the share
    std::vector<std::size_t> deferred;  ///< blocks waiting for the end of pass 1
    ContactSummary summary;             ///< what its gathered blocks saw
  };
  std::vector<Share> shares;
  std::vector<std::size_t> deferred;  ///< every share's deferred blocks, in share order
};

/// What the fused passes saw: pass 1's pairs and pass 2's boundaries (as gather_forces).
struct FusedSummary {
  ContactSummary pairs;
  ContactSummary walls;
};

/// Pass 1 (simd_pair_forces with @p constants, @p criterion_met, @p out, @p history) and pass 2
/// (@p gather, whose pair_forces is @p out) fused as the file says. The shares of @p split serve
/// both passes (a chunk of pass 1 is one block of pass 2); each boundary's force and moment on
/// the particles are summed exactly per share into @p wall_loads, as gather_forces does.
template <bool kFriction, class Law>
FusedSummary fused_pair_passes(const ForceGather<kFriction, false, Law>& gather,
                               std::span<const LanePairConstants> constants,
                               const BondingCriterion& criterion_met, PairForces& out,
                               PairHistory& history, ThreadSplit& split,
                               std::vector<ExactSum>& wall_loads, FusedPassState& state) {
  static_assert(kPairPassChunk == kWallLoadBlock, "a chunk of pass 1 is one block of pass 2");
  const Particles& p = gather.p;
  const NeighborList& list = gather.list;
  const std::size_t blocks = gather.blocks();
  const std::size_t load_values = gather.scene.boundaries.size() * kBoundaryLoadValues;
  split.prepare(blocks, threads_in_use(p.size()));
  const int shares = split.threads();
  wall_loads.assign(static_cast<std::size_t>(shares) * load_values, ExactSum{});
  state.shares.resize(static_cast<std::size_t>(shares));
  for (int t = 0; t < shares; ++t) {
    FusedPassState::Share& share = state.shares[static_cast<std::size_t>(t)];
    share.next_block = split.begin(t);
    share.end_block = split.begin(t + 1);
    share.first_pair = list.row_begins()[std::min(p.size(), share.next_block * kWallLoadBlock)];
    share.waiting.clear();
    share.deferred.clear();
    share.summary = ContactSummary{};
  }
  struct Context {
    const ForceGather<kFriction, false, Law>& gather;
    FusedPassState& state;
    ExactSum* wall_loads;
    std::size_t load_values;
    std::size_t blocks;
  } context{gather, state, wall_loads.data(), load_values, blocks};
  // Gathers the share's blocks whose pairs are all evaluated: the pairs of the share's rows
  // below @p rows. A block waits while one of its transposed pairs lies in a later row of the
  // share (a pair sits in the row of its smaller id, and ids need not follow the order of the
  // particles), and is deferred to the end of pass 1 where one lies in another share's rows.
  const auto on_rows = [](void* opaque, int share_index, std::size_t rows) {
    Context& c = *static_cast<Context*>(opaque);
    FusedPassState::Share& share = c.state.shares[static_cast<std::size_t>(share_index)];
    const NeighborList& pairs_list = c.gather.list;
    const std::size_t n = c.gather.p.size();
    const bool share_done = rows >= std::min(n, share.end_block * kWallLoadBlock);
    const std::size_t complete = share_done ? share.end_block : rows / kWallLoadBlock;
    const std::uint32_t evaluated_end = pairs_list.row_begins()[std::min(n, rows)];
    ExactSum* load = c.wall_loads + static_cast<std::size_t>(share_index) * c.load_values;
    thread_local MeshQueryBuffer buffer;  // reused: mesh queries allocate only while it grows
    const auto gather_block = [&](std::size_t block) {
      // Every particle of the run counts (no decomposition): no uncounted loads.
      c.gather.gather(block, load, nullptr, buffer, share.summary);
    };
    // The waiting blocks whose last transposed pair is now evaluated, in the order they came.
    std::size_t kept = 0;
    for (const FusedPassState::Waiting& w : share.waiting) {
      if (w.transposed_end <= evaluated_end) {
        gather_block(w.block);
      } else {
        share.waiting[kept++] = w;
      }
    }
    share.waiting.resize(kept);
    for (; share.next_block < complete; ++share.next_block) {
      const std::size_t block = share.next_block;
      const std::size_t first = block * kWallLoadBlock;
      const TransposedPairs pairs =
          pairs_list.transposed_pairs(first, std::min(n, first + kWallLoadBlock));
      if (pairs.first < share.first_pair) {
        share.deferred.push_back(block);
      } else if (pairs.end > evaluated_end) {
        share.waiting.push_back({block, pairs.end});
      } else {
        if (c.gather.prefetch && block + 1 < complete) c.gather.prefetch_block(block + 1);
        gather_block(block);
      }
    }
    if (share_done) {  // what still waits has a pair in a later share's rows
      for (const FusedPassState::Waiting& w : share.waiting) share.deferred.push_back(w.block);
      share.waiting.clear();
    }
  };
  const RowsDone rows_done{on_rows, &context};
  FusedSummary summary;
  summary.pairs = simd_pair_forces(p, gather.scene, list, constants, criterion_met, out, history,
                                   nullptr, &split, &rows_done);
  state.deferred.clear();
  for (const FusedPassState::Share& share : state.shares) {
    add_gather_summary(summary.walls, share.summary);
    state.deferred.insert(state.deferred.end(), share.deferred.begin(), share.deferred.end());
  }
  if (state.deferred.empty()) return summary;
  // The deferred blocks in even parts, each thread into its own share's boundary loads.
  const std::vector<std::size_t>& deferred = state.deferred;
#pragma omp parallel num_threads(shares) if (shares > 1 && deferred.size() > 1)
  {
    const auto team = static_cast<std::size_t>(omp_get_num_threads());
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    ContactSummary part;
    ExactSum* load = wall_loads.data() + t * load_values;
    thread_local MeshQueryBuffer buffer;
    for (std::size_t d = deferred.size() * t / team; d < deferred.size() * (t + 1) / team; ++d) {
      gather.gather(deferred[d], load, nullptr, buffer, part);
    }
#pragma omp critical(bondem_fused_pair_passes)
    add_gather_summary(summary.walls, part);
  }
  return summary;
}

}  // namespace bondem
