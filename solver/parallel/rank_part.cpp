#include "solver/parallel/rank_part.hpp"

#include <algorithm>
#include <utility>

namespace bondem {

double decomposition_halo(const Particles& particles, const Scene& scene) {
  double r_max = 0.0;
  for (const double r : particles.radius) r_max = std::max(r_max, r);
  return 2.0 * r_max + scene.contact_range + 2.0 * scene.skin;
}

std::vector<double> stepping_costs(const Stepper& stepper) {
  const NeighborList& list = stepper.neighbors();
  std::vector<double> costs(list.row_begins().size() - 1, 1.0);
  for (std::size_t i = 0; i < costs.size(); ++i) {
    list.for_each_pair_of(
        i, [&](std::uint32_t) { costs[i] += 1.0; }, [&](std::uint32_t) { costs[i] += 1.0; });
  }
  return costs;
}

Scene scene_frame(const Case& c) {
  Scene frame = build_scene(c);
  frame.particles = Particles{};
  frame.initial_pairs = std::vector<SlipRecord>{};
  return frame;
}

RankPart make_rank_part(const Case& c, const Decomposition& decomposition, int rank, double halo,
                        Particles all, StepperState state) {
  return make_rank_part(scene_frame(c), decomposition, rank, halo, std::move(all),
                        std::move(state));
}

RankPart make_rank_part(const Scene& frame, const Decomposition& decomposition, int rank,
                        double halo, Particles all, StepperState state) {
  RankPart part;
  part.scene = std::make_unique<Scene>(frame);
  const std::vector<std::uint32_t> members =
      subdomain_members(decomposition, rank, part.scene->domain, halo, all.x, all.y, all.z);
  for (const std::uint32_t i : members) {
    if (decomposition.owner(all.x[i], all.y[i], all.z[i]) == rank) {
      part.owned_ids.push_back(all.id[i]);
    }
  }
  std::sort(part.owned_ids.begin(), part.owned_ids.end());
  bool every_one_in_order = members.size() == all.size();
  for (std::size_t k = 0; every_one_in_order && k < members.size(); ++k) {
    every_one_in_order = members[k] == k;
  }
  if (every_one_in_order) {
    part.scene->particles = std::move(all);
  } else {
    part.scene->particles = all.selected(members);
    for (StaggeredVector<double>* axis : {&state.list.x0, &state.list.y0, &state.list.z0}) {
      StaggeredVector<double> subset(members.size());
      for (std::size_t k = 0; k < members.size(); ++k) subset[k] = (*axis)[members[k]];
      axis->swap(subset);
    }
  }
  all = Particles{};
  part.stepper = std::make_unique<Stepper>(*part.scene, std::move(state));
  part.stepper->count_only(part.owned_ids);
  return part;
}

StepperState redistribution_state(StepperState state, const Particles& all,
                                  std::vector<SlipRecord> slips) {
  state.list.x0 = all.x;
  state.list.y0 = all.y;
  state.list.z0 = all.z;
  const auto key = [](const SlipRecord& s) { return std::pair(s.first_id, s.second_id); };
  std::sort(slips.begin(), slips.end(),
            [&](const SlipRecord& a, const SlipRecord& b) { return key(a) < key(b); });
  slips.erase(
      std::unique(slips.begin(), slips.end(),
                  [&](const SlipRecord& a, const SlipRecord& b) { return key(a) == key(b); }),
      slips.end());
  state.slips = std::move(slips);
  return state;
}

}  // namespace bondem
