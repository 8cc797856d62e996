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
    sum_shares();  // before a redistribution: new steppers have not evaluated forces
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

  /// The ranks' shares of the last step's figures, added up (counts and exact sums) or
  /// maximized (the largest overlaps); bonds formed and broken over the whole run.
  const ContactSummary& contacts() const { return contacts_; }
  std::int64_t bonds_formed() const { return bonds_formed_; }
  std::int64_t bonds_broken() const { return bonds_broken_; }
  const std::vector<ExactSum>& load_sums() const { return load_sums_; }
  const ExactSum& kinetic_energy() const { return kinetic_energy_; }
  const ExactSum& rotational_energy() const { return rotational_energy_; }

  int redistributions() const { return redistributions_; }
  /// The most particles a rank held (owned and ghosts) at the last distribution.
  std::size_t largest_rank() const { return largest_rank_; }

 private:
  /// Bisects @p all by particle count and gives each rank its part, continuing @p state.
  void distribute(const Particles& all, const StepperState& state) {
    const Scene probe = build_scene(case_);
    const double halo = decomposition_halo(all, probe);
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

  void sum_shares() {
    contacts_ = ContactSummary{};
    load_sums_.clear();
    kinetic_energy_ = rotational_energy_ = ExactSum{};
    for (const RankPart& part : parts_) {
      const ContactSummary& c = part.stepper->contacts();
      contacts_.contacts += c.contacts;
      contacts_.bonds += c.bonds;
      contacts_.wall_contacts += c.wall_contacts;
      contacts_.bonds_formed += c.bonds_formed;
      contacts_.bonds_broken += c.bonds_broken;
      contacts_.max_overlap = std::max(contacts_.max_overlap, c.max_overlap);
      contacts_.max_overlap_fraction =
          std::max(contacts_.max_overlap_fraction, c.max_overlap_fraction);
      const std::vector<ExactSum> loads = part.stepper->boundary_load_sums();
      load_sums_.resize(loads.size());
      for (std::size_t v = 0; v < loads.size(); ++v) load_sums_[v] += loads[v];
      kinetic_energy_ += part.stepper->kinetic_energy_sum();
      rotational_energy_ += part.stepper->rotational_energy_sum();
    }
    bonds_formed_ += static_cast<std::int64_t>(contacts_.bonds_formed);
    bonds_broken_ += static_cast<std::int64_t>(contacts_.bonds_broken);
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
  ContactSummary contacts_;
  std::int64_t bonds_formed_ = 0, bonds_broken_ = 0;
  std::vector<ExactSum> load_sums_;
  ExactSum kinetic_energy_, rotational_energy_;
};

/// Whether the ranks' shares of @p parts add up to the figures of @p whole, bit for bit; what
/// differs goes to the test's log.
bool shares_add_up(const DecomposedRun& parts, const Stepper& whole) {
  const ContactSummary& a = parts.contacts();
  const ContactSummary& b = whole.contacts();
  const std::vector<BoundaryLoad> loads = boundary_loads_of(parts.load_sums());
  const std::vector<BoundaryLoad> expected = whole.boundary_loads();
  bool same_loads = loads.size() == expected.size();
  for (std::size_t k = 0; same_loads && k < loads.size(); ++k) {
    same_loads = loads[k].force == expected[k].force && loads[k].moment == expected[k].moment;
  }
  const bool same = a.contacts == b.contacts && a.bonds == b.bonds &&
                    a.wall_contacts == b.wall_contacts && a.bonds_formed == b.bonds_formed &&
                    a.bonds_broken == b.bonds_broken && a.max_overlap == b.max_overlap &&
                    a.max_overlap_fraction == b.max_overlap_fraction &&
                    parts.bonds_formed() == whole.bonds_formed() &&
                    parts.bonds_broken() == whole.bonds_broken() && same_loads &&
                    parts.kinetic_energy().value() == whole.kinetic_energy() &&
                    parts.rotational_energy().value() == whole.rotational_energy();
  if (!same) {
    ADD_FAILURE() << "step " << whole.step_count() << ": contacts " << a.contacts << " vs "
                  << b.contacts << ", bonds " << a.bonds << " vs " << b.bonds << ", wall contacts "
                  << a.wall_contacts << " vs " << b.wall_contacts << ", formed "
                  << parts.bonds_formed() << " vs " << whole.bonds_formed() << ", loads "
                  << (same_loads ? "equal" : "differ");
  }
  return same;
}

/// Runs the storage-order case (its text with @p appended) whole and on @p ranks ranks for
/// @p steps steps; every owned particle must have the whole run's position, velocity and spin.
/// Returns the whole run's last contact summary.
ContactSummary expect_decomposed_run_follows(const std::string& appended, int ranks, int steps,
                                             const std::vector<std::string>& overrides = {}) {
  const Case c =
      parse_case(testing::file_bytes(BONDEM_TEST_CASES_DIR "/storage_order.yaml") + appended,
                 "storage_order.yaml", overrides);
  Scene whole = build_scene(c);
  Stepper reference(whole);
  DecomposedRun parts(c, ranks, whole.particles, reference.save_state());
  // The ranks' shares must add up to the whole run's figures at every step (each pair counted
  // by the owner of its smaller id, each boundary contact by the particle's owner).
  int steps_adding_up = 0;
  for (int s = 0; s < steps; ++s) {
    reference.step();
    parts.step();
    if (steps_adding_up == s) steps_adding_up += shares_add_up(parts, reference) ? 1 : 0;
  }
  EXPECT_EQ(steps_adding_up, steps) << "the first step whose figures did not add up";
  EXPECT_GT(reference.bonds_formed(), 0);
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

TEST(DecomposedRun, TheHaloHoldsEveryListPartnerOfCohesionReachingBeyondTheSkin) {
  // A JKR contact holds up to its separation distance past touching, so the list reaches
  // r_i + r_j + skin + that range. A particle on a subdomain's face must find every list partner
  // among the ghosts: the halo must exceed every pair's distance at the build, which
  // 2 r_max + 2 skin does not when the range passes the skin (nearly one size here, so that no
  // pair of smaller spheres leaves the halo room to spare).
  const std::string strong =
      "interactions:\n"
      "  - materials: [powder, powder]\n"
      "    cohesion: {model: jkr, surface_energy: 5.0}\n";
  const Case c = parse_case(
      testing::file_bytes(BONDEM_TEST_CASES_DIR "/storage_order.yaml") + strong,
      "storage_order.yaml",
      {"neighbors.skin=5.0e-7", "insert.0.radius.min=0.2599e-3", "insert.0.radius.max=0.26e-3"});
  Scene settled = build_scene(c);
  ASSERT_GT(settled.contact_range, 4.0 * settled.skin) << "the test needs a reach beyond the skin";
  {
    Stepper stepper(settled);
    for (int s = 0; s < 1500; ++s) stepper.step();  // a bed, with pairs near their reach
  }
  Scene scene = build_scene(c);
  scene.particles = settled.particles;
  const Stepper built(scene);  // its list built at these positions
  const Particles& p = scene.particles;
  const double halo = decomposition_halo(p, scene);
  double r_max = 0.0;
  for (const double r : p.radius) r_max = std::max(r_max, r);
  std::size_t beyond_two_skins = 0, outside = 0;
  built.neighbors().for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    const double distance = built.neighbors().separation(p, i, j, k).norm();
    beyond_two_skins += distance > 2.0 * r_max + 2.0 * scene.skin ? 1 : 0;
    outside += distance >= halo ? 1 : 0;
  });
  EXPECT_GT(beyond_two_skins, 50u) << "pairs the list holds beyond 2 r_max + 2 skin";
  EXPECT_EQ(outside, 0u) << "list partners farther apart than the halo " << halo << " m";
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

namespace bondem {
namespace {

TEST(DecomposedRun, ARankThatOwnsNothingCountsNothing) {
  // count_only() with no id (a rank left with ghosts only) must count none of its particles'
  // share, not all of it: the ranks' shares would otherwise add up to more than the whole run.
  const Case c = parse_case(testing::file_bytes(BONDEM_TEST_CASES_DIR "/storage_order.yaml"),
                            "storage_order.yaml");
  Scene counting = build_scene(c);
  Scene silent = build_scene(c);
  Stepper all(counting);
  Stepper none(silent);
  none.count_only({});
  for (int s = 0; s < 200; ++s) {
    all.step();
    none.step();
  }
  ASSERT_GT(all.contacts().contacts, 0u);
  ASSERT_GT(all.kinetic_energy(), 0.0);
  EXPECT_EQ(none.contacts().contacts, 0u);
  EXPECT_EQ(none.contacts().wall_contacts, 0u);
  EXPECT_EQ(none.kinetic_energy(), 0.0);
  for (const BoundaryLoad& load : none.boundary_loads()) {
    EXPECT_EQ(load.force, Eigen::Vector3d::Zero());
  }
  // The largest overlap is a maximum over every pair held, counted or not.
  EXPECT_EQ(none.contacts().max_overlap, all.contacts().max_overlap);
}

}  // namespace
}  // namespace bondem
