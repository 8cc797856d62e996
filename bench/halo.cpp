// The halo of a decomposed run: for a case bisected into R subdomains, how many ghosts each rank
// holds beside the particles it owns, and the bytes its ghost refresh moves per step. Usage:
//   bench_halo CASE [R ...]      (default R: 2 4 8 16)
// One line per R: owned and ghosts per rank (mean and largest), the halo fraction (ghosts over
// owned, the largest rank's), and the bytes of the largest rank's ghosts per step.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "solver/engine/scene.hpp"
#include "solver/parallel/decomposition.hpp"
#include "solver/parallel/particle_transfer.hpp"
#include "solver/parallel/rank_part.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_halo CASE [R ...]\n");
    return 2;
  }
  try {
    const bondem::Scene scene = bondem::build_scene(bondem::load_case(argv[1]));
    const bondem::Particles& p = scene.particles;
    std::vector<int> rank_counts;
    for (int a = 2; a < argc; ++a) rank_counts.push_back(std::atoi(argv[a]));
    if (rank_counts.empty()) rank_counts = {2, 4, 8, 16};
    std::vector<char> record;
    bondem::pack_particle(p, 0, record);
    const double halo = bondem::decomposition_halo(p, scene);
    std::printf("%s: %zu particles, halo %.4g m, %zu B per particle record\n", argv[1], p.size(),
                halo, record.size());
    std::printf(
        "ranks,owned_mean,owned_max,ghosts_mean,ghosts_max,halo_fraction_max,"
        "ghost_bytes_per_step_max\n");
    const std::vector<double> cost(p.size(), 1.0);
    for (const int ranks : rank_counts) {
      const bondem::Decomposition d = bondem::bisect(
          p.x, p.y, p.z, cost, p.id, bondem::Box{scene.domain.min, scene.domain.max}, ranks, halo);
      std::vector<std::size_t> owned(static_cast<std::size_t>(ranks), 0);
      for (std::size_t i = 0; i < p.size(); ++i) {
        ++owned[static_cast<std::size_t>(d.owner(p.x[i], p.y[i], p.z[i]))];
      }
      double owned_sum = 0.0, ghost_sum = 0.0, worst_fraction = 0.0;
      std::size_t owned_max = 0, ghost_max = 0;
      for (int r = 0; r < ranks; ++r) {
        const std::size_t members =
            bondem::subdomain_members(d, r, scene.domain, halo, p.x, p.y, p.z).size();
        const std::size_t mine = owned[static_cast<std::size_t>(r)];
        const std::size_t ghosts = members - mine;
        owned_sum += static_cast<double>(mine);
        ghost_sum += static_cast<double>(ghosts);
        owned_max = std::max(owned_max, mine);
        ghost_max = std::max(ghost_max, ghosts);
        worst_fraction =
            std::max(worst_fraction, static_cast<double>(ghosts) / static_cast<double>(mine));
      }
      std::printf("%d,%.0f,%zu,%.0f,%zu,%.4f,%zu\n", ranks, owned_sum / ranks, owned_max,
                  ghost_sum / ranks, ghost_max, worst_fraction, ghost_max * record.size());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_halo: %s\n", e.what());
    return 1;
  }
  return 0;
}
