// What this CPU's divider gives a scalar kernel: latency and throughput of double-precision
// square root and division, the operations the friction law's chains are made of (see README,
// "Where the time goes"). A lower bound for a contact is (its roots + divisions) x throughput;
// a chain of them costs their latencies. Built without auto-vectorisation, like the scalar law.
//
//   bench_fp_limits   (counter ns_per_op: time per operation)
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>

namespace {

constexpr int kOps = 1024;  // operations per iteration, per chain

/// One dependent chain: every operation waits for the previous result (latency).
void BM_SqrtLatency(benchmark::State& state) {
  double x = 1.5;
  for (auto _ : state) {
    for (int k = 0; k < kOps; ++k) x = std::sqrt(x + 1.0);  // converges to the golden ratio
    benchmark::DoNotOptimize(x);
  }
  state.counters["ns_per_op"] =
      benchmark::Counter(static_cast<double>(kOps) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_DivLatency(benchmark::State& state) {
  double x = 1.5;
  for (auto _ : state) {
    for (int k = 0; k < kOps; ++k) x = 1.0 / (x + 1.0);  // converges to 1 / golden ratio
    benchmark::DoNotOptimize(x);
  }
  state.counters["ns_per_op"] =
      benchmark::Counter(static_cast<double>(kOps) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

/// Eight independent chains: as many operations in flight as the unit accepts (throughput).
void BM_SqrtThroughput(benchmark::State& state) {
  std::array<double, 8> x{1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8};
  for (auto _ : state) {
    for (int k = 0; k < kOps; ++k) {
      for (double& v : x) v = std::sqrt(v + 1.0);
    }
    benchmark::DoNotOptimize(x);
  }
  state.counters["ns_per_op"] =
      benchmark::Counter(8.0 * kOps * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_DivThroughput(benchmark::State& state) {
  std::array<double, 8> x{1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8};
  for (auto _ : state) {
    for (int k = 0; k < kOps; ++k) {
      for (double& v : x) v = 1.0 / (v + 1.0);
    }
    benchmark::DoNotOptimize(x);
  }
  state.counters["ns_per_op"] =
      benchmark::Counter(8.0 * kOps * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

}  // namespace

BENCHMARK(BM_SqrtLatency);
BENCHMARK(BM_DivLatency);
BENCHMARK(BM_SqrtThroughput);
BENCHMARK(BM_DivThroughput);
BENCHMARK_MAIN();
