/// @file core_latency.cpp
/// Core-to-core latency: two threads, pinned to two CPUs, hand one cache line back and forth;
/// prints the median one-way time of a few short trials. `bench_core_latency [CPU_A CPU_B]`
/// (default 0 1).
///
/// Why: on this virtual machine the host moves the two vCPUs between cores that share a level-3
/// cache (about 30 ns one way) and cores on different dies (about 170 ns), every few seconds to
/// minutes. Two independent one-thread runs do not notice; a two-thread bondem run does (its
/// threads share cache lines: the particles and force slots one writes and the other reads).
/// bench/compare_peers.sh runs this probe beside every two-core run and reports the ratios of
/// each placement apart.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "pin_cpu.hpp"

namespace {

using bondem::bench::pin_to;

/// The shared line: the counter each side waits on, alone in its cache line.
struct alignas(64) Line {
  std::atomic<std::uint64_t> counter{0};
};

/// One trial of @p handoffs round trips between @p cpu_a (the calling thread) and @p cpu_b,
/// after as many unmeasured ones (the partner's start and move to its CPU): nanoseconds one way.
double one_way_ns(int cpu_a, int cpu_b, std::uint64_t handoffs) {
  if (!pin_to(cpu_a)) {
    std::fprintf(stderr, "bench_core_latency: cannot run on CPU %d\n", cpu_a);
    std::exit(2);
  }
  Line line;
  const std::uint64_t total = 2 * handoffs;
  std::atomic<bool> pinned_b{true};
  std::thread partner([&line, &pinned_b, cpu_b, total] {
    pinned_b = pin_to(cpu_b);
    for (std::uint64_t k = 0; k < total; ++k) {
      while (line.counter.load(std::memory_order_acquire) != 2 * k + 1) {
      }
      line.counter.store(2 * k + 2, std::memory_order_release);
    }
  });
  std::chrono::steady_clock::time_point start;
  for (std::uint64_t k = 0; k < total; ++k) {
    if (k == handoffs) start = std::chrono::steady_clock::now();
    line.counter.store(2 * k + 1, std::memory_order_release);
    while (line.counter.load(std::memory_order_acquire) != 2 * k + 2) {
    }
  }
  const auto end = std::chrono::steady_clock::now();
  partner.join();
  if (!pinned_b) {
    std::fprintf(stderr, "bench_core_latency: cannot run on CPU %d\n", cpu_b);
    std::exit(2);
  }
  const double ns = std::chrono::duration<double, std::nano>(end - start).count();
  return ns / (2.0 * static_cast<double>(handoffs));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 1 && argc != 3) {
    std::fprintf(stderr, "usage: bench_core_latency [CPU_A CPU_B]\n");
    return 2;
  }
  const int cpu_a = argc == 3 ? std::atoi(argv[1]) : 0;
  const int cpu_b = argc == 3 ? std::atoi(argv[2]) : 1;
  // Five trials of 20 000 measured round trips: under 0.1 s, short enough to sit beside each run.
  std::vector<double> trials;
  for (int t = 0; t < 5; ++t) trials.push_back(one_way_ns(cpu_a, cpu_b, 20000));
  std::nth_element(trials.begin(), trials.begin() + 2, trials.end());
  std::printf("core_to_core_ns = %.1f\n", trials[2]);
  return 0;
}
