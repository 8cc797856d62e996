// The pair kernel (pass 1) alone, per contact: the bond law with alpha_adh = 1 and a general
// alpha_adh, with and without friction, on unbonded and bonded pairs, over packings of three
// solid fractions (simple-cubic 0.52, body-centred 0.68, face-centred 0.74 lattices whose
// nearest neighbours overlap by 1e-3 of a radius), at several particle counts, through the scalar
// pass (target -1) and the SIMD pass on each target this CPU supports (1 scalar, 2 sse4, 3 avx2,
// 4 avx512: SimdTarget). alpha_adh = 0.5 has no SIMD form (std::pow) and runs the scalar pass only.
//
//   bench_kernel --benchmark_filter=Friction   (counters: contacts_per_second, pairs_per_contact)
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "solver/engine/contact_kernel.hpp"
#include "solver/engine/pair_kernel_simd.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace {

using namespace bondem;

constexpr double kRadius = 1e-3;

/// A periodic lattice block of about @p target particles: kind 0 SC, 1 BCC, 2 FCC.
Scene packing(int kind, std::size_t target, bool friction, bool bonded, double alpha) {
  static const std::array<std::vector<Eigen::Vector3d>, 3> bases{{
      {{0, 0, 0}},
      {{0, 0, 0}, {0.5, 0.5, 0.5}},
      {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}},
  }};
  // Cell edge that puts nearest neighbours at 2 r (1 - 1e-3).
  const std::array<double, 3> nearest_per_edge{1.0, std::sqrt(3.0) / 2.0, std::sqrt(0.5)};
  const auto k = static_cast<std::size_t>(kind);
  const double edge = 2.0 * kRadius * (1.0 - 1e-3) / nearest_per_edge[k];
  const auto cells = static_cast<int>(
      std::ceil(std::cbrt(static_cast<double>(target) / static_cast<double>(bases[k].size()))));
  Case c;
  c.source = "bench";
  c.materials.push_back({"powder", 2000.0, 1.0e9, 0.3});
  c.contact.damping_ratio = 0.2;
  c.contact.friction = friction ? 0.5 : 0.0;
  c.contact.bond.criterion = bonded ? BondCriterion::kAlways : BondCriterion::kNever;
  // Bonded: delta_eq above the lattice overlap (2e-6 m), which is above delta_crit = 4/9 delta_eq.
  c.contact.bond.equilibrium_overlap = 3e-6;
  c.contact.bond.damping_ratio = 1.0;
  c.contact.bond.alpha = alpha;
  c.time_step = 1e-7;
  for (int x = 0; x < cells; ++x) {
    for (int y = 0; y < cells; ++y) {
      for (int z = 0; z < cells; ++z) {
        for (const Eigen::Vector3d& b : bases[k]) {
          ParticleSpec p;
          p.radius = kRadius;
          p.position = edge * (Eigen::Vector3d(x, y, z) + b + Eigen::Vector3d::Constant(0.25));
          c.particles.push_back(p);
        }
      }
    }
  }
  Domain d;
  d.max = Eigen::Vector3d::Constant(cells * edge);
  d.periodic = {true, true, true};
  c.domain = d;
  c.skin = 0.1 * kRadius;
  return build_scene(c);
}

/// Pass 1 over a packing whose one material pair has friction (kFriction), bonds or not, with
/// adhesion exponent @p alpha, through the pass of state.range(2) (-1 scalar, else a SimdTarget).
template <bool kFriction>
void pair_pass(benchmark::State& state, bool bonded, double alpha) {
  const bool simd = state.range(2) >= 0;
  const auto target = static_cast<SimdTarget>(state.range(2));
  if (simd) {
    const std::vector<SimdTarget> usable = supported_simd_targets();
    if (std::find(usable.begin(), usable.end(), target) == usable.end()) {
      state.SkipWithError("target not supported by this CPU");
      return;
    }
    select_simd_target(target);
  }
  Scene scene = packing(static_cast<int>(state.range(0)), static_cast<std::size_t>(state.range(1)),
                        kFriction, bonded, alpha);
  if (simd && !simd_pass_applies(scene)) {
    state.SkipWithError("no SIMD form for this model");
    return;
  }
  const std::vector<LanePairConstants> constants = lane_pair_constants(scene);
  const BondNormalLaw law;
  Stepper stepper(scene);  // builds the list and checks the packing evaluates
  const NeighborList& list = stepper.neighbors();
  PairForces forces;
  forces.resize(list.pair_count(), kFriction, scene.rolling(), false);
  PairHistory history;
  history.resize(list.pair_count(), kFriction, false);
  const BondingCriterion criterion{scene.particles, forces.bonded, nullptr};
  ContactSummary summary;
  LanePassScratch scratch;  // as a stepper keeps it
  for (auto _ : state) {
    summary = simd ? simd_pair_forces(scene.particles, scene, list, constants, criterion, forces,
                                      history, nullptr, nullptr, &scratch)
                   : compute_pair_forces<kFriction, false>(scene.particles, scene, list, law,
                                                           criterion, forces, history);
    benchmark::DoNotOptimize(forces.fx.data());
  }
  if (bonded && summary.bonds != summary.contacts) state.SkipWithError("pairs are not bonded");
  const auto contacts = static_cast<double>(summary.contacts);
  state.counters["particles"] = static_cast<double>(scene.particles.size());
  state.counters["contacts_per_particle"] = contacts / static_cast<double>(scene.particles.size());
  state.counters["pairs_per_contact"] = static_cast<double>(list.pair_count()) / contacts;
  state.counters["threads"] = omp_get_max_threads();
  state.counters["contacts_per_second"] = benchmark::Counter(
      contacts * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Pairs_Hertz_Alpha1(benchmark::State& s) {
  pair_pass<false>(s, false, 1.0);
}
void BM_Pairs_Bonded_Alpha1(benchmark::State& s) {
  pair_pass<false>(s, true, 1.0);
}
void BM_Pairs_Bonded_Alpha05(benchmark::State& s) {
  pair_pass<false>(s, true, 0.5);
}
void BM_Pairs_Friction_Alpha1(benchmark::State& s) {
  pair_pass<true>(s, false, 1.0);
}
void BM_Pairs_Friction_Bonded_Alpha1(benchmark::State& s) {
  pair_pass<true>(s, true, 1.0);
}

/// {lattice: 0 SC, 1 BCC, 2 FCC} x {about 8 000, 64 000 particles} x {pass: -1 scalar, SIMD
/// targets 1 scalar, 2 sse4, 3 avx2, 4 avx512}.
void sweep(benchmark::internal::Benchmark* b) {
  for (const int kind : {0, 1, 2}) {
    for (const int count : {8000, 64000}) {
      for (const int target : {-1, 1, 2, 3, 4}) b->Args({kind, count, target});
    }
  }
  b->ArgNames({"lattice", "particles", "target"})->Unit(benchmark::kMillisecond);
}

}  // namespace

BENCHMARK(BM_Pairs_Hertz_Alpha1)->Apply(sweep);
BENCHMARK(BM_Pairs_Bonded_Alpha1)->Apply(sweep);
BENCHMARK(BM_Pairs_Bonded_Alpha05)->Apply(sweep);
BENCHMARK(BM_Pairs_Friction_Alpha1)->Apply(sweep);
BENCHMARK(BM_Pairs_Friction_Bonded_Alpha1)->Apply(sweep);
BENCHMARK_MAIN();
