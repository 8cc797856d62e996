#pragma once
/// @file rank_part.hpp
/// One rank's part of a decomposed run: a scene of its own with the particles it owns and its
/// halo, and the stepper that advances them.

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/parallel/decomposition.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// The halo of a decomposed run of @p particles in @p scene: the largest pair reach (2 r_max, plus
/// the JKR separation distance scene.contact_range) plus twice the skin (a partner in the list was
/// within r_i + r_j + contact_range + skin at the build, and each has moved less than half a skin
/// since), so that each owned particle's step depends on the halo alone.
double decomposition_halo(const Particles& particles, const Scene& scene);

/// The weights that bisect() balances, per particle of @p stepper's scene in its order: 1 plus
/// the pairs of the neighbor list the particle belongs to, the work of its sweeps and of its
/// pairs, so that a heap or a dense bed does not leave the ranks of a dilute region idle.
std::vector<double> stepping_costs(const Stepper& stepper);

/// A rank's scene, which of its particles it owns (the rest are ghosts, which their owners
/// refresh every step) and its stepper. Ownership is kept by id: a list rebuild may
/// reorder the scene's particles.
struct RankPart {
  std::unique_ptr<Scene> scene;
  std::vector<std::int64_t> owned_ids;  ///< sorted: valid until the next distribution
  std::unique_ptr<Stepper> stepper;

  /// Whether the particle of id @p id is owned here.
  bool owns(std::int64_t id) const {
    return std::binary_search(owned_ids.begin(), owned_ids.end(), id);
  }
};

/// Rank @p rank's part of @p all under @p decomposition: a copy of @p frame (a scene of the
/// run; its particles are not read: pass it without them, scene_frame()) with the owned particles
/// and those within @p halo, its stepper continuing @p state (whose list build positions are
/// those of @p all; its pairs' state is taken by the particles' ids), counting only the owned
/// particles' share (Stepper::count_only). When @p all holds just the part's particles (a
/// restart that read only them), the part takes them without a copy.
RankPart make_rank_part(const Scene& frame, const Decomposition& decomposition, int rank,
                        double halo, Particles all, StepperState state);

/// The same, with the frame built from case @p c.
RankPart make_rank_part(const Case& c, const Decomposition& decomposition, int rank, double halo,
                        Particles all, StepperState state);

/// The scene of case @p c without its particles and initial pairs: what every rank part copies.
Scene scene_frame(const Case& c);

/// The state to distribute @p all from right after a list rebuild: @p state (any rank's: time,
/// step, boundaries and the build count are the same on all) with the list's build positions set
/// to the positions of @p all, at which the list was just built, and the pairs' state @p slips
/// (every rank's, concatenated) sorted by ids with duplicates dropped (ranks that hold the same
/// pair hold the same state).
StepperState redistribution_state(StepperState state, const Particles& all,
                                  std::vector<SlipRecord> slips);

}  // namespace bondem
