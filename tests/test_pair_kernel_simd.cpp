// The SIMD pass (pair_kernel_simd.hpp) against the scalar pass (compute_pair_forces), pair by
// pair, on a jittered packing of two materials with every branch the lanes have: contacts and
// gaps, Hertz and bonds (delta_eq input for one material pair, k_adh input for the other),
// sticking and sliding friction with stored springs, rolling resistance, spinning particles; and
// the targets against each other, bit for bit.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "run_helpers.hpp"
#include "solver/engine/contact_kernel.hpp"
#include "solver/engine/fused_pass.hpp"
#include "solver/engine/pair_kernel_simd.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

constexpr double kRadius = 1e-3;

/// @p per_axis^3 (9^3 unless said) spheres of radius 0.9-1.1 mm on a 2 mm grid, jittered by up to
/// 0.08 mm: overlaps from gaps of a few tenths of a millimetre to about 0.3 mm; materials
/// alternate. With @p walls, gravity and a floor and a ceiling that cut into the bottom and top
/// layers.
Scene jittered_packing(int per_axis = 9, bool walls = false) {
  Case c;
  c.source = "test";
  c.materials.push_back({"a", 2000.0, 1.0e8, 0.3});
  c.materials.push_back({"b", 3000.0, 2.0e8, 0.25});
  c.contact.damping_ratio = 0.2;
  c.contact.friction = 0.5;
  c.contact.rolling_friction = 0.1;
  c.contact.bond.criterion = BondCriterion::kAlways;
  c.contact.bond.equilibrium_overlap = 6e-5;  // delta_crit = 4/9 of it: some pairs bond
  c.contact.bond.damping_ratio = 1.0;
  Interaction mixed;
  mixed.first_material = 0;
  mixed.second_material = 1;
  mixed.model = c.contact;
  mixed.model.friction = 0.3;
  mixed.model.bond.input = AdhesionInput::kStiffness;
  mixed.model.bond.stiffness = 40.0;  // delta_eq = (k_adh / k_h)^2, about 7e-5 m here
  c.interactions.push_back(mixed);
  c.time_step = 1e-7;
  std::mt19937_64 random(42);
  std::uniform_real_distribution<double> jitter(-8e-5, 8e-5);
  std::uniform_real_distribution<double> size(0.9 * kRadius, 1.1 * kRadius);
  for (int x = 0; x < per_axis; ++x) {
    for (int y = 0; y < per_axis; ++y) {
      for (int z = 0; z < per_axis; ++z) {
        ParticleSpec p;
        p.material = (x + y + z) % 2;
        p.radius = size(random);
        p.position = 2.0 * kRadius * Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5) +
                     Eigen::Vector3d(jitter(random), jitter(random), jitter(random));
        c.particles.push_back(p);
      }
    }
  }
  Domain d;
  d.max = Eigen::Vector3d::Constant(2.0 * per_axis * kRadius);
  d.periodic = {true, true, false};  // pairs across the periodic faces take image shifts
  c.domain = d;
  c.skin = 0.1 * kRadius;
  if (walls) {
    c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
    const double top = 2.0 * per_axis * kRadius;
    c.boundaries.push_back(plane_boundary(Eigen::Vector3d(0.0, 0.0, 0.2 * kRadius),
                                          Eigen::Vector3d::UnitZ(), 0, "floor"));
    c.boundaries.push_back(plane_boundary(Eigen::Vector3d(0.0, 0.0, top - 0.2 * kRadius),
                                          -Eigen::Vector3d::UnitZ(), 1, "ceiling"));
  }
  Scene scene = build_scene(c);
  std::uniform_real_distribution<double> speed(-0.1, 0.1);
  std::uniform_real_distribution<double> spin(-100.0, 100.0);
  Particles& p = scene.particles;
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.vx[i] = speed(random);
    p.vy[i] = speed(random);
    p.vz[i] = speed(random);
    // A third spin slowly: there the rolling torque's cap I* |omega| / dt (about 3e-5 N m s per
    // rad/s here) binds instead of mu_r r* F_n.
    const double scale = i % 3 == 0 ? 1e-4 : 1.0;
    p.wx[i] = scale * spin(random);
    p.wy[i] = scale * spin(random);
    p.wz[i] = scale * spin(random);
  }
  return scene;
}

/// Springs of random direction and length up to 2e-6 m, or 1e-11 m for a third of the pairs:
/// those stick, the others slide.
PairHistory random_springs(std::size_t pairs) {
  PairHistory history;
  history.resize(pairs, true, false);
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> elongation(-2e-6, 2e-6);
  for (std::size_t k = 0; k < pairs; ++k) {
    const double scale = k % 3 == 0 ? 5e-6 : 1.0;
    history.sx[k] = scale * elongation(random);
    history.sy[k] = scale * elongation(random);
    history.sz[k] = scale * elongation(random);
  }
  return history;
}

struct PassResult {
  PairForces forces;
  PairHistory history;
  ContactSummary summary;
};

PassResult run_pass(const Scene& scene, const NeighborList& list, bool simd) {
  PassResult r;
  r.forces.resize(list.pair_count(), true, true, false);
  r.history = random_springs(list.pair_count());
  const BondingCriterion criterion{scene.particles, r.forces.bonded, nullptr};
  if (simd) {
    r.summary = simd_pair_forces(scene.particles, scene, list, lane_pair_constants(scene),
                                 criterion, r.forces, r.history);
  } else {
    r.summary = compute_pair_forces<true, false>(scene.particles, scene, list, BondNormalLaw{},
                                                 criterion, r.forces, r.history);
  }
  return r;
}

/// Every per-pair array of @p r, in one list, for comparisons.
std::vector<const StaggeredVector<double>*> arrays(const PassResult& r) {
  const PairForces& f = r.forces;
  return {&f.fx,     &f.fy,     &f.fz,      &f.cx,         &f.cy,         &f.cz,        &f.roll_x,
          &f.roll_y, &f.roll_z, &f.overlap, &r.history.sx, &r.history.sy, &r.history.sz};
}

/// Whether @p a and @p b hold the same bytes (== would take -0 for +0).
bool same_bytes(const StaggeredVector<double>& a, const StaggeredVector<double>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), testing::same_bits);
}

/// Expects every per-pair array of @p got to hold the bytes of @p expected's.
void expect_same_bits(const PassResult& got, const PassResult& expected) {
  const auto want = arrays(expected);
  const auto have = arrays(got);
  for (std::size_t a = 0; a < want.size(); ++a)
    EXPECT_TRUE(same_bytes(*have[a], *want[a])) << "array " << a;
}

TEST(PairKernelSimd, PackingTakesTheSimdPass) {
  const Scene scene = jittered_packing();
  EXPECT_TRUE(simd_pass_applies(scene));
  EXPECT_EQ(scene.material_count, 2);
}

TEST(PairKernelSimd, MatchesTheScalarPassOnEveryBranch) {
  Scene scene = jittered_packing();
  NeighborList list;
  list.build(scene.particles, scene.domain, scene.skin, false);
  const PassResult scalar = run_pass(scene, list, false);
  // The packing must exercise every branch, or the comparison proves little.
  ASSERT_GT(scalar.summary.contacts, 500U);
  ASSERT_GT(scalar.summary.bonds, 50U);
  ASSERT_LT(scalar.summary.bonds, scalar.summary.contacts);
  ASSERT_LT(scalar.summary.contacts, list.pair_count());
  // Sliding contacts have their springs cut to the Coulomb limit (far below 1e-7 m here), sticking
  // ones keep theirs (above 1e-11 m after a step of v_t dt).
  const PairHistory before = random_springs(list.pair_count());
  std::size_t sliding = 0, sticking = 0;
  for (std::size_t k = 0; k < list.pair_count(); ++k) {
    if (scalar.forces.overlap[k] <= 0.0) continue;
    const double s = std::hypot(scalar.history.sx[k], scalar.history.sy[k], scalar.history.sz[k]);
    const double s0 = std::hypot(before.sx[k], before.sy[k], before.sz[k]);
    sliding += s < 0.5 * s0 && s0 > 1e-8 ? 1 : 0;
    sticking += s0 < 1e-10 && s > 0.0 ? 1 : 0;
  }
  ASSERT_GT(sliding, 10U);
  ASSERT_GT(sticking, 50U);
  for (const SimdTarget target : supported_simd_targets()) {
    select_simd_target(target);
    const PassResult lanes = run_pass(scene, list, true);
    SCOPED_TRACE(simd_target_name(target));
    EXPECT_EQ(lanes.summary.contacts, scalar.summary.contacts);
    EXPECT_EQ(lanes.summary.bonds, scalar.summary.bonds);
    EXPECT_EQ(lanes.summary.bonds_formed, scalar.summary.bonds_formed);
    EXPECT_EQ(lanes.summary.max_overlap, scalar.summary.max_overlap);  // the same subtraction
    EXPECT_NEAR(lanes.summary.max_overlap_fraction, scalar.summary.max_overlap_fraction, 1e-15);
    EXPECT_EQ(lanes.forces.bonded, scalar.forces.bonded);
    // The lanes reorder the arithmetic (one reciprocal for 1/d, r* and m*; a = sqrt(r* delta)
    // instead of sqrt(r*) sqrt(delta)): each value agrees to a few ulps of the largest of its
    // kind, 1e-12 relative leaves three orders of margin and still catches any wrong term.
    const auto expected = arrays(scalar);
    const auto got = arrays(lanes);
    for (std::size_t a = 0; a < expected.size(); ++a) {
      double scale = 0.0;
      for (double v : *expected[a]) scale = std::max(scale, std::abs(v));
      ASSERT_GT(scale, 0.0) << "array " << a << " never set";
      ASSERT_EQ(got[a]->size(), list.pair_count()) << "array " << a;
      for (std::size_t k = 0; k < list.pair_count(); ++k) {
        ASSERT_NEAR((*got[a])[k], (*expected[a])[k], 1e-12 * scale)
            << "array " << a << " pair " << k;
      }
    }
  }
  select_simd_target(SimdTarget::kAuto);
}

TEST(PairKernelSimd, EveryTargetGivesTheSameBits) {
  Scene scene = jittered_packing();
  NeighborList list;
  list.build(scene.particles, scene.domain, scene.skin, false);
  select_simd_target(SimdTarget::kScalar);
  const PassResult reference = run_pass(scene, list, true);
  for (const SimdTarget target : supported_simd_targets()) {
    select_simd_target(target);
    const PassResult lanes = run_pass(scene, list, true);
    SCOPED_TRACE(simd_target_name(target));
    expect_same_bits(lanes, reference);
  }
  select_simd_target(SimdTarget::kAuto);
}

// From 32 768 particles on, each block prefetches the next block's j particles from the list
// (pair_kernel_simd.cpp): the pass reads the list ahead up to its last pair and no further (the
// sanitizer run would catch a read past the list's allocation), and every target still gives the
// same bits, those of the scalar pass's contacts and bonds.
TEST(PairKernelSimd, ALargePackingPrefetchesAndKeepsTheBits) {
  Scene scene = jittered_packing(33);
  ASSERT_GE(scene.particles.size(), 32768U);
  NeighborList list;
  list.build(scene.particles, scene.domain, scene.skin, false);
  const PassResult scalar = run_pass(scene, list, false);
  select_simd_target(SimdTarget::kScalar);
  const PassResult reference = run_pass(scene, list, true);
  EXPECT_EQ(reference.summary.contacts, scalar.summary.contacts);
  EXPECT_EQ(reference.forces.bonded, scalar.forces.bonded);
  for (const SimdTarget target : supported_simd_targets()) {
    select_simd_target(target);
    const PassResult lanes = run_pass(scene, list, true);
    SCOPED_TRACE(simd_target_name(target));
    expect_same_bits(lanes, reference);
  }
  select_simd_target(SimdTarget::kAuto);
}

/// For a jittered packing of @p per_axis^3 spheres per entry of @p sizes, on every supported
/// target: the pass with the limit that @p set_limit moves at 0 (one way at every size) and at its
/// largest (the other way) gives the same contacts, bond flags and bits in every per-pair array;
/// the limit is restored. @p check_at_zero(per_axis, result) sees each run at limit 0.
template <class Check>
void expect_both_ways_give_the_same_bits(std::initializer_list<int> sizes,
                                         std::size_t (*set_limit)(std::size_t),
                                         Check check_at_zero) {
  for (const int per_axis : sizes) {
    Scene scene = jittered_packing(per_axis);
    NeighborList list;
    list.build(scene.particles, scene.domain, scene.skin, false);
    for (const SimdTarget target : supported_simd_targets()) {
      select_simd_target(target);
      const std::size_t limit = set_limit(0);
      const PassResult at_zero = run_pass(scene, list, true);
      set_limit(std::numeric_limits<std::size_t>::max());
      const PassResult at_largest = run_pass(scene, list, true);
      set_limit(limit);
      SCOPED_TRACE(std::string(simd_target_name(target)) + ", " + std::to_string(per_axis) + "^3");
      check_at_zero(per_axis, at_zero);
      EXPECT_EQ(at_largest.summary.contacts, at_zero.summary.contacts);
      EXPECT_EQ(at_largest.forces.bonded, at_zero.forces.bonded);
      expect_same_bits(at_largest, at_zero);
    }
  }
  select_simd_target(SimdTarget::kAuto);
}

// The block gather reads each particle's kinematics from the records (below
// set_kinematics_records_below's limit, 2^19 particles by default) or from the particle arrays:
// both must give the same bits, on the small packing and on the large one, which also prefetches
// the records.
TEST(PairKernelSimd, RecordsAndParticleArraysGiveTheSameBits) {
  expect_both_ways_give_the_same_bits({9, 33}, set_kinematics_records_below,
                                      [](int /*per_axis*/, const PassResult& /*from_arrays*/) {});
}

// Out of cache the lanes write the force slots with streaming stores (whole vectors at their
// alignment, the rest as before): the same values as cached stores, on every target, whether a
// thread's rows start on a vector boundary or not. The large packing's slot arrays are over 1 MiB,
// so they start on a cache line (StaggeredAllocator) and most of their vectors are streamed.
TEST(PairKernelSimd, StreamedAndCachedSlotsGiveTheSameBits) {
  expect_both_ways_give_the_same_bits(
      {9, 40}, set_stream_pair_slots_from, [](int per_axis, const PassResult& streamed) {
        if (per_axis == 40) {  // else the streamed path would be taken by chance only
          EXPECT_EQ(reinterpret_cast<std::uintptr_t>(streamed.forces.fx.data()) % 64, 0U);
        }
      });
}

// Stepper::step() lets the opening sweep write the pass's kinematics records; move() followed by
// complete_step() (a decomposed run's step) leaves the pass to copy them from the particle arrays.
// Both must move every particle alike, bit for bit, through rebuilds that reorder the particles
// in memory: a record left over from before a rebuild would give another particle's kinematics.
// The test turns the records on at every size (restored on exit), whatever the default limit.
TEST(PairKernelSimd, RecordsWrittenByTheSweepMatchRecordsCopiedByThePass) {
  struct RecordsOn {
    std::size_t limit = set_kinematics_records_below(std::numeric_limits<std::size_t>::max());
    ~RecordsOn() { set_kinematics_records_below(limit); }
  } records_on;
  Scene swept = jittered_packing();
  Scene copied = jittered_packing();
  for (Scene* scene : {&swept, &copied}) {
    scene->reorder_interval = 1;        // every rebuild reorders
    scene->max_overlap_fraction = 0.5;  // the packing's deepest overlaps are 0.29 of a radius
    // The whole packing sails along x at 100 m/s: the same contacts, but particles change cells
    // (each rebuild reorders them) and cross the periodic faces (each rebuild wraps them).
    for (double& vx : scene->particles.vx) vx += 100.0;
  }
  Stepper by_step(swept);
  Stepper by_parts(copied);
  const double half_skin = 0.5 * copied.skin;
  for (int s = 0; s < 600; ++s) {
    by_step.step();
    by_parts.complete_step(by_parts.move() > half_skin * half_skin);
  }
  // 6 mm of travel, half a skin (0.05 mm) every 5 steps.
  EXPECT_GE(by_step.neighbors().build_count(), 100);
  EXPECT_EQ(by_step.neighbors().build_count(), by_parts.neighbors().build_count());
  ASSERT_EQ(swept.particles.size(), copied.particles.size());
  for (std::size_t i = 0; i < swept.particles.size(); ++i) {
    ASSERT_EQ(swept.particles.id[i], copied.particles.id[i]);
    ASSERT_TRUE(testing::same_motion(swept.particles, i, copied.particles, i)) << "particle " << i;
  }
}

// Below set_pair_records_below's limit a frictional run without rolling resistance keeps its
// pairs as 64-B records (PairForces::records), which the lanes write transposed and pass 2 adds in
// lanes, a record a visit; otherwise the seven arrays and scalar adds. Both must move every
// particle alike, bit for bit, on every target, through rebuilds that reorder the particles, with
// bonds, sliding contacts and gaps (the packing's): a force that differed at any step would
// have moved a particle.
TEST(PairKernelSimd, PairRecordsAndPairArraysGiveTheSameBits) {
  const std::size_t limit = set_pair_records_below(0);
  for (const SimdTarget target : supported_simd_targets()) {
    select_simd_target(target);
    SCOPED_TRACE(simd_target_name(target));
    Scene in_records = jittered_packing();
    Scene in_arrays = jittered_packing();
    for (Scene* scene : {&in_records, &in_arrays}) {
      for (PairCoefficients& pair : scene->pair_table) pair.rolling_friction = 0.0;
      scene->reorder_interval = 1;        // every rebuild reorders
      scene->max_overlap_fraction = 0.5;  // the packing's deepest overlaps are 0.29 of a radius
      for (double& vx : scene->particles.vx) vx += 100.0;  // rebuilds every few steps
    }
    Stepper with_records(in_records);
    Stepper with_arrays(in_arrays);
    for (int s = 0; s < 120; ++s) {
      set_pair_records_below(std::numeric_limits<std::size_t>::max());
      with_records.step();
      set_pair_records_below(0);
      with_arrays.step();
      ASSERT_TRUE(with_records.pair_forces().in_records());
      ASSERT_FALSE(with_arrays.pair_forces().in_records());
    }
    EXPECT_GE(with_records.neighbors().build_count(), 10);
    EXPECT_GT(with_records.contacts().contacts, 0U);
    ASSERT_EQ(in_records.particles.size(), in_arrays.particles.size());
    for (std::size_t i = 0; i < in_records.particles.size(); ++i) {
      ASSERT_EQ(in_records.particles.id[i], in_arrays.particles.id[i]);
      ASSERT_TRUE(testing::same_motion(in_records.particles, i, in_arrays.particles, i))
          << "particle " << i;
    }
  }
  set_pair_records_below(limit);
  select_simd_target(SimdTarget::kAuto);
}

// Out of cache pass 2 sums each particle's pair forces in one loop and its pair torques in a
// second (PairSums::kForce, then kTorque) where below kSplitPairSumsParticles one loop sums both:
// every component must come out the same bits, with rolling torques and without, on pair slots that
// the lanes filled for a packing with gaps, bonds, sliding and spinning spheres.
TEST(PairKernelSimd, PassTwoInTwoLoopsGivesTheSameBitsAsInOne) {
  Scene scene = jittered_packing();
  scene.gravity = Eigen::Vector3d(0.3, -2.0, -9.81);
  NeighborList list;
  list.build(scene.particles, scene.domain, scene.skin, false);
  const PassResult pass = run_pass(scene, list, true);
  ASSERT_GT(pass.summary.contacts, 0U);
  const std::size_t n = scene.particles.size();
  for (const bool rolling : {false, true}) {
    PairForces slots = pass.forces;
    if (!rolling) {
      for (StaggeredVector<double>* r : {&slots.roll_x, &slots.roll_y, &slots.roll_z}) r->clear();
    }
    Particles one_loop = scene.particles;
    Particles two_loops = scene.particles;
    // Odd bounds, as the threads' shares and the runs of blocks give.
    for (const auto& [first, end] : {std::pair<std::size_t, std::size_t>{0, 37}, {37, n}}) {
      if (rolling) {
        gather_pair_range_into<true, true>(one_loop, list, slots, scene.gravity, first, end);
        gather_pair_range_into<true, true, PairSums::kTorque>(two_loops, list, slots, scene.gravity,
                                                              first, end);
      } else {
        gather_pair_range_into<true, false>(one_loop, list, slots, scene.gravity, first, end);
        gather_pair_range_into<true, false, PairSums::kTorque>(two_loops, list, slots,
                                                               scene.gravity, first, end);
      }
      gather_pair_range_into<true, false, PairSums::kForce>(two_loops, list, slots, scene.gravity,
                                                            first, end);
    }
    SCOPED_TRACE(rolling ? "rolling" : "no rolling");
    for (auto member : {&Particles::fx, &Particles::fy, &Particles::fz, &Particles::tx,
                        &Particles::ty, &Particles::tz}) {
      EXPECT_TRUE(same_bytes(two_loops.*member, one_loop.*member));
      // Not trivially equal: the sums moved the arrays from their starting zeros.
      EXPECT_FALSE(same_bytes(two_loops.*member, scene.particles.*member));
    }
  }
}

// The same in whole steps, where pass 2 adds the walls' contacts after each run's two loops: on a
// packing of several runs of blocks with contacts in the first and the last blocks (a floor and a
// ceiling), 40 steps with pass 2 in two loops at every size, then in one, move every particle the
// same bits and load both walls alike (the threshold restored on exit).
TEST(PairKernelSimd, StepsWithPassTwoInTwoLoopsMatchStepsWithOne) {
  struct Restore {
    std::size_t from = set_split_pair_sums_from(0);
    ~Restore() { set_split_pair_sums_from(from); }
  } restore;
  Scene two_loops = jittered_packing(17, true);
  Scene one_loop = jittered_packing(17, true);
  ASSERT_GT(one_loop.particles.size(), kSplitPairSumsBlocks * kWallLoadBlock);  // two runs
  for (Scene* scene : {&two_loops, &one_loop}) scene->max_overlap_fraction = 0.5;
  Stepper split(two_loops);
  for (int s = 0; s < 40; ++s) split.step();
  set_split_pair_sums_from(std::numeric_limits<std::size_t>::max());
  Stepper whole(one_loop);
  for (int s = 0; s < 40; ++s) whole.step();
  ASSERT_EQ(two_loops.particles.size(), one_loop.particles.size());
  for (std::size_t i = 0; i < one_loop.particles.size(); ++i) {
    ASSERT_TRUE(testing::same_motion(two_loops.particles, i, one_loop.particles, i))
        << "particle " << i;
  }
  EXPECT_EQ(split.contacts().wall_contacts, whole.contacts().wall_contacts);
  for (std::size_t wall = 0; wall < 2; ++wall) {
    const Eigen::Vector3d split_load = split.boundary_loads()[wall].force;
    const Eigen::Vector3d whole_load = whole.boundary_loads()[wall].force;
    EXPECT_NE(whole_load.z(), 0.0) << "wall " << wall;  // both walls hold contacts
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_TRUE(testing::same_bits(split_load[axis], whole_load[axis]))
          << "wall " << wall << ", axis " << axis;
    }
  }
}

// Drifting ahead (Stepper::drift_ahead) takes each step's closing kicks and the next one's opening
// kicks and drift as pass 2 completes each range of particles, and moves the boundaries after
// pass 2 instead of before the next sweep. On the walled packing with a ceiling pressing down
// and sliding, 30 steps so taken (then one settled) must move every particle, both walls' loads
// and the ceiling the same bits as 31 settled steps; with pass 2 in runs of blocks (each run
// drifted after its sums) and block by block.
TEST(PairKernelSimd, StepsDriftedAheadMatchSettledSteps) {
  struct Restore {
    std::size_t from = set_split_pair_sums_from(0);
    ~Restore() { set_split_pair_sums_from(from); }
  } restore;
  constexpr int kSteps = 31;
  for (const std::size_t split_from : {std::size_t{0}, std::numeric_limits<std::size_t>::max()}) {
    set_split_pair_sums_from(split_from);
    enum class Way { kSettled, kDriftedAhead };
    std::vector<Scene> scenes;
    scenes.reserve(2);  // each stepper holds its scene
    std::vector<std::unique_ptr<Stepper>> steppers;
    int drifted_steps = 0;
    for (const Way way : {Way::kSettled, Way::kDriftedAhead}) {
      Scene& scene = scenes.emplace_back(jittered_packing(17, true));
      scene.max_overlap_fraction = 0.5;
      scene.boundaries[1].motion.keys = {{0.0, Eigen::Vector3d(0.05, 0.0, -0.5), 0.0}};
      Stepper& stepper = *steppers.emplace_back(std::make_unique<Stepper>(scene));
      for (int s = 0; s < kSteps; ++s) {
        stepper.drift_ahead(way == Way::kDriftedAhead && s + 1 < kSteps);
        stepper.step();
        drifted_steps += stepper.drifted() ? 1 : 0;
      }
      EXPECT_FALSE(stepper.drifted());  // the last step settles
    }
    EXPECT_EQ(drifted_steps, kSteps - 1);  // the drift ahead was taken
    const Particles& settled = scenes[0].particles;
    for (std::size_t way = 1; way < scenes.size(); ++way) {
      const Particles& other = scenes[way].particles;
      ASSERT_EQ(other.size(), settled.size());
      for (std::size_t i = 0; i < settled.size(); ++i) {
        ASSERT_TRUE(testing::same_motion(other, i, settled, i))
            << "way " << way << ", particle " << i << ", pass 2 in two loops from " << split_from;
      }
      EXPECT_EQ(steppers[way]->contacts().wall_contacts, steppers[0]->contacts().wall_contacts);
      for (std::size_t wall = 0; wall < 2; ++wall) {
        const Eigen::Vector3d load = steppers[way]->boundary_loads()[wall].force;
        const Eigen::Vector3d settled_load = steppers[0]->boundary_loads()[wall].force;
        EXPECT_NE(settled_load.z(), 0.0) << "wall " << wall;  // both walls hold contacts
        for (int axis = 0; axis < 3; ++axis) {
          EXPECT_TRUE(testing::same_bits(load[axis], settled_load[axis]))
              << "way " << way << ", wall " << wall << ", axis " << axis;
          EXPECT_TRUE(testing::same_bits(scenes[way].boundaries[1].center[axis],
                                         scenes[0].boundaries[1].center[axis]))
              << "way " << way << ", ceiling, axis " << axis;
        }
      }
    }
  }
}

// The fused pass (fused_pass.hpp) runs pass 2 and the drift of each run of rows right behind its
// pass 1, from a ring of records, and the particles whose pairs the ring no longer holds or another
// thread's rows hold at the end from the records it kept: every sum in its order, so the bits of
// the two passes. On the walled packing (ids grow along every axis, as the cells do) with a
// sliding ceiling, sailing across the periodic faces (rebuilds that reorder), with runs of 256
// rows and a ring of 1 024 pairs or more (particles wait: wraps and pairs out of reach), on one
// thread and two (particles wait at the cut), with a drift ahead and without, its lanes reading
// kinematics records and the two passes' the arrays: 30 steps must move every particle and load
// both walls as the two passes do.
TEST(PairKernelSimd, FusedPassGivesTheBitsOfTheTwoPasses) {
  struct Restore {
    std::size_t from = set_fused_pass_from(0);
    std::pair<std::size_t, std::uint32_t> shape = set_fused_pass_shape(256, 1024);
    std::size_t kinematics = set_kinematics_records_below(0);
    std::size_t records = set_pair_records_below(0);
    int threads = omp_get_max_threads();
    ~Restore() {
      set_fused_pass_from(from);
      set_fused_pass_shape(shape.first, shape.second);
      set_kinematics_records_below(kinematics);
      set_pair_records_below(records);
      omp_set_num_threads(threads);
    }
  } restore;
  constexpr int kSteps = 30;
  for (const int threads : {1, 2}) {
    omp_set_num_threads(threads);
    for (const bool ahead : {true, false}) {
      SCOPED_TRACE(std::to_string(threads) +
                   (ahead ? " threads, drift ahead" : " threads, settled"));
      std::vector<Scene> scenes;
      scenes.reserve(2);  // each stepper holds its scene
      std::vector<std::unique_ptr<Stepper>> steppers;
      for (const bool fused : {true, false}) {
        set_fused_pass_from(fused ? 0 : std::numeric_limits<std::size_t>::max());
        Scene& scene = scenes.emplace_back(jittered_packing(17, true));
        for (PairCoefficients& pair : scene.pair_table) pair.rolling_friction = 0.0;
        scene.max_overlap_fraction = 0.5;
        scene.reorder_interval = 1;
        scene.pair_forces_read = false;  // else the two passes run
        scene.boundaries[1].motion.keys = {{0.0, Eigen::Vector3d(0.05, 0.0, -0.5), 0.0}};
        for (double& vx : scene.particles.vx) vx += 20.0;  // a rebuild every few dozen steps
        Stepper& stepper = *steppers.emplace_back(std::make_unique<Stepper>(scene));
        for (int s = 0; s < kSteps; ++s) {
          stepper.drift_ahead(ahead && s + 1 < kSteps);
          stepper.step();
        }
        EXPECT_FALSE(stepper.drifted());
        EXPECT_GE(stepper.neighbors().build_count(), 2);
        if (fused) {
          EXPECT_EQ(stepper.fused_evaluations(), kSteps + 1);  // the initial one as well
        } else {
          EXPECT_EQ(stepper.fused_evaluations(), 0);
        }
      }
      const Particles& fused = scenes[0].particles;
      const Particles& two_passes = scenes[1].particles;
      ASSERT_EQ(fused.size(), two_passes.size());
      for (std::size_t i = 0; i < fused.size(); ++i) {
        ASSERT_TRUE(testing::same_motion(fused, i, two_passes, i)) << "particle " << i;
      }
      EXPECT_EQ(steppers[0]->contacts().contacts, steppers[1]->contacts().contacts);
      EXPECT_EQ(steppers[0]->contacts().wall_contacts, steppers[1]->contacts().wall_contacts);
      for (std::size_t wall = 0; wall < 2; ++wall) {
        const Eigen::Vector3d load = steppers[0]->boundary_loads()[wall].force;
        const Eigen::Vector3d two_pass_load = steppers[1]->boundary_loads()[wall].force;
        EXPECT_NE(two_pass_load.z(), 0.0) << "wall " << wall;  // both walls hold contacts
        for (int axis = 0; axis < 3; ++axis) {
          EXPECT_TRUE(testing::same_bits(load[axis], two_pass_load[axis]))
              << "wall " << wall << ", axis " << axis;
        }
      }
    }
  }
}

// Where a particle's pairs lie far from it in memory (the packing's ids shuffled: a pair sits in
// the row of its smaller id, anywhere), more than an eighth of the particles would wait: the plan
// says so, and the stepper takes the two passes.
TEST(PairKernelSimd, FusedPassStandsAsideWhereMostParticlesWouldWait) {
  struct Restore {
    std::size_t from = set_fused_pass_from(0);
    std::pair<std::size_t, std::uint32_t> shape = set_fused_pass_shape(256, 1024);
    std::size_t kinematics = set_kinematics_records_below(0);
    std::size_t records = set_pair_records_below(0);
    ~Restore() {
      set_fused_pass_from(from);
      set_fused_pass_shape(shape.first, shape.second);
      set_kinematics_records_below(kinematics);
      set_pair_records_below(records);
    }
  } restore;
  Scene scene = jittered_packing(17, true);
  for (PairCoefficients& pair : scene.pair_table) pair.rolling_friction = 0.0;
  scene.max_overlap_fraction = 0.5;
  scene.pair_forces_read = false;
  std::mt19937_64 random(7);
  std::shuffle(scene.particles.id.begin(), scene.particles.id.end(), random);
  Stepper stepper(scene);
  for (int s = 0; s < 3; ++s) stepper.step();
  EXPECT_EQ(stepper.fused_evaluations(), 0);
  FusedPlan plan;
  plan_fused_pass(stepper.neighbors(), scene.particles.size(), true, 1, plan);
  EXPECT_FALSE(plan.usable);
  EXPECT_TRUE(plan.waits.empty());  // nothing kept for it
}

TEST(PairKernelSimd, TargetNamesRoundTrip) {
  for (const SimdTarget target : {SimdTarget::kAuto, SimdTarget::kScalar, SimdTarget::kSse4,
                                  SimdTarget::kAvx2, SimdTarget::kAvx512}) {
    EXPECT_EQ(parse_simd_target(simd_target_name(target)), target);
  }
  EXPECT_FALSE(parse_simd_target("neon"));
  const std::vector<SimdTarget> usable = supported_simd_targets();
  ASSERT_FALSE(usable.empty());
  EXPECT_EQ(usable.front(), SimdTarget::kScalar);  // every CPU runs the scalar target
}

}  // namespace
}  // namespace bondem
