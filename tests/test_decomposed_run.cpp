// A decomposed run in one process: the ranks of a distributed run played by scenes of their own,
// with ghosts copied from their owners after every step, a rebuild agreed by all, and the
// particles redistributed (migration, new halos, rebalanced cuts) at every rebuild. Every particle
// must follow the undecomposed run bit for bit: what MPI will then carry between processes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/case_file.hpp"
#include "run_helpers.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/parallel/decomposition.hpp"
#include "solver/parallel/particle_transfer.hpp"
#include "solver/parallel/rank_part.hpp"

namespace bondem {
namespace {

/// The ranks of a decomposed run, each a RankPart.
class DecomposedRun {
 public:
  DecomposedRun(const Case& c, int ranks, const Particles& particles, StepperState state)
      : case_(c), ranks_(ranks) {
    distribute(particles, std::move(state));
  }

  /// One step on every rank: the rebuild is taken by all when any needs it.
  void step() {
    double largest = 0.0;
    for (const RankPart& part : parts_) largest = std::max(largest, part.stepper->move());
    const double half_skin = 0.5 * parts_.front().scene->skin;
    const bool rebuild = largest > half_skin * half_skin;
    for (const RankPart& part : parts_) part.stepper->complete_step(rebuild);
    if (rebuild) {
      ++redistributions_;
      gather_and_distribute();
    } else {
      refresh_ghosts();
    }
  }

  /// Calls @p visit(particles, index) for every particle where its owner holds it.
  template <class Visit>
  void for_each_owned(Visit&& visit) const {
    for (const RankPart& part : parts_) {
      for (std::size_t k = 0; k < part.scene->particles.size(); ++k) {
        if (part.owns(part.scene->particles.id[k])) visit(part.scene->particles, k);
      }
    }
  }

  int redistributions() const { return redistributions_; }
  /// The most particles a rank held (owned and ghosts) at the last distribution.
  std::size_t largest_rank() const { return largest_rank_; }

 private:
  /// Bisects @p all by particle count and gives each rank its part, continuing @p state.
  void distribute(const Particles& all, const StepperState& state) {
    const Scene probe = build_scene(case_);
    const double halo = decomposition_halo(all, probe.skin);
    const std::vector<double> cost(all.size(), 1.0);
    const Decomposition d = bisect(all.x, all.y, all.z, cost, all.id,
                                   Box{probe.domain.min, probe.domain.max}, ranks_, halo);
    parts_.clear();
    owner_of_.clear();
    largest_rank_ = 0;
    for (int r = 0; r < ranks_; ++r) {
      parts_.push_back(make_rank_part(case_, d, r, halo, all, state));
      const Particles& p = parts_.back().scene->particles;
      for (std::size_t k = 0; k < p.size(); ++k) {
        if (parts_.back().owns(p.id[k])) owner_of_[p.id[k]] = {static_cast<std::size_t>(r), k};
      }
      largest_rank_ = std::max(largest_rank_, p.size());
    }
  }

  /// Every ghost takes its owner's state (what MPI sends after each step).
  void refresh_ghosts() {
    for (RankPart& part : parts_) {
      Particles& p = part.scene->particles;
      for (std::size_t k = 0; k < p.size(); ++k) {
        if (part.owns(p.id[k])) continue;
        const auto [rank, index] = owner_of_.at(p.id[k]);
        copy_particle(parts_[rank].scene->particles, index, p, k);
      }
    }
  }

  /// After a rebuild: the owned particles of every rank, and the union of the pairs' state,
  /// distributed anew (a rebuild reorders each rank's particles, so owners are found by id).
  void gather_and_distribute() {
    Particles all = parts_.front().scene->particles;
    all.permute({});
    std::vector<SlipRecord> slips;
    for (const RankPart& part : parts_) {
      const Particles& p = part.scene->particles;
      for (std::size_t k = 0; k < p.size(); ++k) {
        if (part.owns(p.id[k])) append_particle(p, k, all);
      }
      const std::vector<SlipRecord> held = part.stepper->save_state().slips;
      slips.insert(slips.end(), held.begin(), held.end());
    }
    distribute(all,
               redistribution_state(parts_.front().stepper->save_state(), all, std::move(slips)));
  }

  Case case_;
  int ranks_;
  std::vector<RankPart> parts_;
  std::map<std::int64_t, std::pair<std::size_t, std::size_t>> owner_of_;  ///< id -> rank, index
  int redistributions_ = 0;
  std::size_t largest_rank_ = 0;
};

/// Runs the storage-order case (its text with @p appended) whole and on @p ranks ranks for
/// @p steps steps; every owned particle must have the whole run's position, velocity and spin.
/// Returns the whole run's last contact summary.
ContactSummary expect_decomposed_run_follows(const std::string& appended, int ranks, int steps) {
  const Case c =
      parse_case(testing::file_bytes(BONDEM_TEST_CASES_DIR "/storage_order.yaml") + appended,
                 "storage_order.yaml");
  Scene whole = build_scene(c);
  Stepper reference(whole);
  DecomposedRun parts(c, ranks, whole.particles, reference.save_state());
  for (int s = 0; s < steps; ++s) {
    reference.step();
    parts.step();
  }
  EXPECT_GT(parts.redistributions(), 3) << "the run must rebuild, and so redistribute";
  EXPECT_LT(parts.largest_rank(), whole.particles.size()) << "a rank must hold a part only";
  std::map<std::int64_t, std::size_t> index_of;
  for (std::size_t i = 0; i < whole.particles.size(); ++i) index_of[whole.particles.id[i]] = i;
  std::size_t owned = 0, differing = 0;
  parts.for_each_owned([&](const Particles& p, std::size_t k) {
    ++owned;
    differing += testing::same_motion(p, k, whole.particles, index_of.at(p.id[k])) ? 0 : 1;
  });
  EXPECT_EQ(owned, whole.particles.size()) << ranks << " ranks: each particle owned once";
  EXPECT_EQ(differing, 0u) << ranks << " ranks";
  return reference.contacts();
}

TEST(DecomposedRun, CohesiveRunFollowsTheWholeRunBitForBit) {
  // JKR cohesion: the scalar pair pass, contacts held past zero overlap (a pair state that must
  // migrate with the particles), on 2 ranks.
  const ContactSummary contacts = expect_decomposed_run_follows(
      "interactions:\n"
      "  - materials: [powder, powder]\n"
      "    cohesion: {model: jkr, surface_energy: 0.05}\n",
      2, 2000);
  EXPECT_GT(contacts.contacts, 100u);
}

TEST(DecomposedRun, EveryParticleFollowsTheWholeRunBitForBit) {
  // The bonded, frictional case across periodic x and y with a floor and a moving blade, on 2
  // and 3 ranks: bonds form and break across the cuts, particles cross them and the periodic
  // faces, and every rebuild redistributes (57 times in 3 000 steps). A halo of r_max instead of
  // 2 r_max + 2 skin leaves 700 particles off; so does a rebuild that one rank skips.
  for (const int ranks : {2, 3}) {
    EXPECT_GT(expect_decomposed_run_follows("", ranks, 3000).bonds, 100u);
  }
}

}  // namespace
}  // namespace bondem
