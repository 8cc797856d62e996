// Microbenchmarks of the bond law, the innermost piece of every force evaluation.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "solver/models/bond_law.hpp"
#include "solver/models/pair.hpp"

namespace {

/// Paper-like pair (E* = 0.5 GPa, r* = 0.5 mm) with overlaps spread over Hertz and bond ranges.
struct Inputs {
  bondem::BondPair pair;
  std::vector<double> overlap, rate;
};

Inputs make_inputs(double alpha, std::size_t n) {
  const auto c = bondem::make_pair_coefficients(5e8, 0.2, 0.5, alpha,
                                                bondem::AdhesionInput::kEquilibriumOverlap, 5e-5);
  Inputs in{bondem::make_bond_pair(c, 5e-4, 4.18879e-6), {}, {}};
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> overlap(1e-7, 1e-4), rate(-1.0, 1.0);
  for (std::size_t k = 0; k < n; ++k) {
    in.overlap.push_back(overlap(rng));
    in.rate.push_back(rate(rng));
  }
  return in;
}

template <class Adhesion>
void run(benchmark::State& state, Adhesion adhesion, double alpha, bool criterion) {
  const Inputs in = make_inputs(alpha, 4096);
  for (auto _ : state) {
    double sum = 0.0;
    for (std::size_t k = 0; k < in.overlap.size(); ++k) {
      sum += bondem::normal_force(in.pair, adhesion, in.overlap[k], in.rate[k], criterion).force;
    }
    benchmark::DoNotOptimize(sum);
  }
  state.counters["contacts_per_second"] = benchmark::Counter(
      static_cast<double>(state.iterations() * in.overlap.size()), benchmark::Counter::kIsRate);
}

void BM_BondLaw_Alpha1(benchmark::State& s) {
  run(s, bondem::LinearAdhesion{}, 1.0, true);
}
void BM_BondLaw_AlphaGeneral(benchmark::State& s) {
  run(s, bondem::GeneralAdhesion{0.8}, 0.8, true);
}
void BM_HertzOnly(benchmark::State& s) {
  run(s, bondem::LinearAdhesion{}, 1.0, false);
}

}  // namespace

BENCHMARK(BM_BondLaw_Alpha1);
BENCHMARK(BM_BondLaw_AlphaGeneral);
BENCHMARK(BM_HertzOnly);
BENCHMARK_MAIN();
