// Strong and weak scaling of whole time steps on a settled-like dense lattice (the peers' kind of
// case), and memory per particle. Usage:
//   bench_scaling [--friction] [--steps N] [--sizes 1000,10000,...] [--threads T] > scaling.csv
// One row per (particles, threads): particle-steps per second, speed-up, efficiency, and the peak
// resident memory of the process divided by the particle count (a bound from above: the peak of
// everything the process ran so far). --threads T runs only T threads; bench/scaling.sh runs each
// row in its own process, so each row's memory is that configuration's alone. Speed-up and
// efficiency are against the 1-thread row of the same process (1.0 when it did not run).
#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "lattice_case.hpp"
#include "solver/engine/stepper.hpp"

namespace {

using namespace bondem;

/// A lattice of about @p target spheres, 13 layers high.
Scene lattice(std::size_t target, bool friction) {
  const int side =
      std::max(3, static_cast<int>(std::lround(std::sqrt(static_cast<double>(target) / 13.0))));
  return bench::lattice_scene(side, 13, friction);
}

double peak_resident_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) * 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace

int main(int argc, char** argv) {
  bool friction = false;
  int steps = 200;
  int only_threads = 0;
  std::vector<std::size_t> sizes = {1000, 10000, 100000, 1000000};
  for (int a = 1; a < argc; ++a) {
    if (std::strcmp(argv[a], "--friction") == 0) {
      friction = true;
    } else if (std::strcmp(argv[a], "--steps") == 0 && a + 1 < argc) {
      steps = std::atoi(argv[++a]);
    } else if (std::strcmp(argv[a], "--threads") == 0 && a + 1 < argc) {
      only_threads = std::atoi(argv[++a]);
    } else if (std::strcmp(argv[a], "--sizes") == 0 && a + 1 < argc) {
      sizes.clear();
      std::stringstream list(argv[++a]);
      for (std::string item; std::getline(list, item, ',');) sizes.push_back(std::stoul(item));
    } else {
      std::fprintf(stderr, "usage: %s [--friction] [--steps N] [--sizes a,b,c] [--threads T]\n",
                   argv[0]);
      return 2;
    }
  }
  const int max_threads = omp_get_max_threads();
  std::printf(
      "particles,threads,particle_steps_per_second,speedup,efficiency,peak_bytes_per_particle\n");
  for (const std::size_t target : sizes) {
    double single = 0.0;
    for (int threads = 1; threads <= std::max(max_threads, only_threads); ++threads) {
      if (only_threads > 0 && threads != only_threads) continue;
      omp_set_num_threads(threads);
      Scene scene = lattice(target, friction);
      Stepper stepper(scene);
      // As a run steps between outputs: each step's closing kicks merge with the next's sweep,
      // taken as its pass 2 ends; the last step settles.
      stepper.drift_ahead(true);
      for (int s = 0; s < 20; ++s) stepper.step();  // warm up caches and the neighbor list
      const auto start = std::chrono::steady_clock::now();
      for (int s = 0; s < steps; ++s) {
        stepper.drift_ahead(s + 1 < steps);
        stepper.step();
      }
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const double n = static_cast<double>(scene.particles.size());
      const double rate = n * steps / seconds;
      if (threads == 1 || single == 0.0) single = rate;
      std::printf("%zu,%d,%.4g,%.3f,%.3f,%.0f\n", scene.particles.size(), threads, rate,
                  rate / single, rate / single / threads, peak_resident_bytes() / n);
      std::fflush(stdout);
    }
  }
  return 0;
}
