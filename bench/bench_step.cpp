// Whole-step and neighbor-build benchmarks on a dense frictional lattice like the peers' case
// (shared/peers): spheres of 1 mm on a simple-cubic lattice of 1.999 mm (neighbors slightly
// overlapped), periodic in x and y, a floor, gravity.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <vector>

#include "lattice_case.hpp"
#include "solver/engine/pair_kernel_simd.hpp"
#include "solver/engine/stepper.hpp"

namespace {

using namespace bondem;

using bench::lattice_scene;

void run_steps(benchmark::State& state, bool friction) {
  const auto side = static_cast<int>(state.range(0));
  Scene scene = lattice_scene(side, 13, friction);
  Stepper stepper(scene);
  // As a run steps between outputs: each step's closing kicks merge with the next's sweep.
  stepper.drift_ahead(true);
  for (auto _ : state) stepper.step();
  const auto particles = static_cast<double>(scene.particles.size());
  state.counters["particles"] = particles;
  state.counters["threads"] = omp_get_max_threads();
  state.counters["particle_steps_per_second"] = benchmark::Counter(
      particles * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Step_Frictionless(benchmark::State& state) {
  run_steps(state, false);
}
void BM_Step_Friction(benchmark::State& state) {
  run_steps(state, true);
}

/// A step of the frictional lattice on a floor that is a plane or a 100 352-triangle mesh of the
/// same plane: what a mesh costs over an analytic boundary in the same packing (issue 15 target:
/// at most 1.5x). Run both interleaved: --benchmark_filter=Floor
/// --benchmark_repetitions=10 --benchmark_enable_random_interleaving=true.
void floor_steps(benchmark::State& state, bench::Floor floor) {
  Scene scene = lattice_scene(static_cast<int>(state.range(0)), 13, true, floor);
  Stepper stepper(scene);
  stepper.drift_ahead(true);  // as run_steps
  for (auto _ : state) stepper.step();
  state.counters["particles"] = static_cast<double>(scene.particles.size());
  state.counters["wall_contacts"] = static_cast<double>(stepper.contacts().wall_contacts);
}
void BM_Step_FloorPlane(benchmark::State& state) {
  floor_steps(state, bench::Floor::kPlane);
}
void BM_Step_FloorMesh(benchmark::State& state) {
  floor_steps(state, bench::Floor::kMesh);
}

/// Two variants of the step that give the same bytes, paired in one process: the host's drift
/// (runs of one binary scatter by 15-20 % on the shared machine) moves both alike. Runs of
/// @p unit steps alternate between the variants (which goes first alternates too) and the
/// counters give each one's median time per step and the median of the paired ratios
/// variant / reference (below 1: the variant is faster). Every step of a unit but its last
/// drifts ahead (as run_steps), and the variants switch at the settled state between units;
/// @p use(Stepper&, bool variant, bool last) switches before each step, last for the unit's last
/// step.
template <class Use>
void paired_steps(benchmark::State& state, Use&& use, int unit = 1) {
  Scene scene = lattice_scene(static_cast<int>(state.range(0)), 13, true);
  Stepper stepper(scene);
  for (int s = 0; s < 5; ++s) stepper.step();  // first touches, the splits' first moves
  std::vector<double> variant, reference, ratio;
  const auto timed_step = [&](bool is_variant) {
    const auto start = std::chrono::steady_clock::now();
    for (int s = 0; s < unit; ++s) {
      stepper.drift_ahead(s + 1 < unit);
      use(stepper, is_variant, s + 1 == unit);
      stepper.step();
    }
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
               .count() /
           unit;
  };
  for (auto _ : state) {
    const bool variant_first = variant.size() % 2 == 0;
    const double first = timed_step(variant_first);
    const double second = timed_step(!variant_first);
    variant.push_back(variant_first ? first : second);
    reference.push_back(variant_first ? second : first);
    ratio.push_back(variant.back() / reference.back());
  }
  use(stepper, false, true);
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  state.counters["variant_ms"] = median(variant);
  state.counters["reference_ms"] = median(reference);
  state.counters["ratio"] = median(ratio);
}

/// Threads that take chunks from the back of slower threads' shares (ThreadSplit::run) against
/// each thread alone on its share; meaningful with OMP_NUM_THREADS >= 2.
void BM_Step_StealingPaired(benchmark::State& state) {
  paired_steps(state, [](Stepper&, bool variant, bool) { ThreadSplit::set_stealing(variant); });
  ThreadSplit::set_stealing(true);
}

/// Kinematics records at every size (variant) against the particle arrays at every size
/// (reference), whatever the default limit. Biased against the records: each variant step maps
/// their pages again, since the reference's pass frees them; whole runs of two builds are the
/// fairer measure.
void BM_Step_RecordsPaired(benchmark::State& state) {
  const std::size_t limit = set_kinematics_records_below(0);  // each step sets its own
  paired_steps(state, [](Stepper&, bool variant, bool) {
    set_kinematics_records_below(variant ? std::numeric_limits<std::size_t>::max() : 0);
  });
  set_kinematics_records_below(limit);
}

/// The force slots written with streaming stores at every size (variant) against the default
/// limit (reference): where streaming pays, and where it does not.
void BM_Step_StreamPaired(benchmark::State& state) {
  const std::size_t limit = set_stream_pair_slots_from(0);  // each step sets its own
  paired_steps(state, [limit](Stepper&, bool variant, bool) {
    set_stream_pair_slots_from(variant ? 0 : std::numeric_limits<std::size_t>::max());
  });
  set_stream_pair_slots_from(limit);
}

/// Steps that take their closing sweep and the next step's opening sweep as their pass 2 ends
/// (Stepper::drift_ahead, variant) against settled steps (reference): in runs of eight, all but
/// the last drifting ahead, as a run between outputs takes them.
void BM_Step_DriftAheadPaired(benchmark::State& state) {
  paired_steps(
      state,
      [](Stepper& stepper, bool variant, bool last) { stepper.drift_ahead(variant && !last); }, 8);
}

void BM_NeighborBuild(benchmark::State& state) {
  Scene scene = lattice_scene(static_cast<int>(state.range(0)), 13, false);
  NeighborList list;
  for (auto _ : state) list.build(scene.particles, scene.domain, 1e-4, false);
  state.counters["pairs_per_particle"] =
      static_cast<double>(list.pair_count()) / static_cast<double>(scene.particles.size());
  state.counters["particles_per_second"] =
      benchmark::Counter(static_cast<double>(scene.particles.size() * state.iterations()),
                         benchmark::Counter::kIsRate);
}

}  // namespace

// 10 x 10 x 13 = 1300 particles up to the peers' 40 x 40 x 13 = 20 800; the neighbor build also at
// 277 x 277 x 13 = 997 477 (the peers' scale), where its serial parts and page faults show.
BENCHMARK(BM_Step_Frictionless)->Arg(10)->Arg(20)->Arg(40)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_Friction)->Arg(10)->Arg(20)->Arg(40)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_FloorPlane)->Arg(20)->Arg(40)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_FloorMesh)->Arg(20)->Arg(40)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_StealingPaired)->Arg(10)->Arg(40)->Arg(277)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_RecordsPaired)
    ->Arg(10)
    ->Arg(40)
    ->Arg(100)
    ->Arg(277)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_StreamPaired)
    ->Arg(10)
    ->Arg(40)
    ->Arg(60)
    ->Arg(70)
    ->Arg(100)
    ->Arg(277)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_DriftAheadPaired)->Arg(40)->Arg(277)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_NeighborBuild)->Arg(10)->Arg(40)->Arg(277)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
