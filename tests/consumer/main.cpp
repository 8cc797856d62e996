// Uses the installed bondem engine alone: an undamped Hertz collision rebounds elastically.
#include <cstdio>

#include "solver/experiments/collision.hpp"

int main() {
  bondem::Case c;
  c.source = "consumer";
  c.materials.push_back({"glass", 2500.0, 1.0e9, 0.3});
  c.contact.bond.criterion = bondem::BondCriterion::kNever;
  c.contact.bond.equilibrium_overlap = 1e-6;
  c.time_step = 1e-8;  // over a thousand steps per contact
  c.end_time = 1e-3;
  c.particles.push_back({0, 1e-3, {0.0, 0.0, 0.0}});
  c.particles.push_back({0, 1e-3, {2e-3, 0.0, 0.0}});
  const bondem::CollisionResult r = bondem::collide(c, 1.0);
  std::printf("restitution = %.6f\n", r.restitution);
  // Velocity Verlet conserves energy to O(dt^2): at this step e = 1 within 1e-4.
  return r.restitution > 0.9999 && r.restitution < 1.0001 ? 0 : 1;
}
