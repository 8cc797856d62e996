#pragma once
// Small case builders shared by the multi-particle tests.
#include <cmath>

#include "solver/setup/case.hpp"
#include "solver/setup/insertion.hpp"

namespace bondem::testing {

/// One soft material (E = 5 MPa, nu = 0.3, rho = 2500), no bonding, given contact damping.
inline Case soft_case(double xi_con) {
  Case c;
  c.source = "test";
  c.materials.push_back({"powder", 2500.0, 5.0e6, 0.3});
  c.contact.damping_ratio = xi_con;
  c.contact.bond.criterion = BondCriterion::kNever;
  c.contact.bond.equilibrium_overlap = 1e-6;
  c.time_step = 1e-6;
  c.end_time = 1.0;
  return c;
}

/// A row of @p count spheres of radius 1 mm (E = 100 MPa) resting on a frictionless floor plane
/// named "floor", 2.1 mm apart along x from x = 4 mm, periodic across y, under gravity.
inline Case row_on_floor(int count, double xi_con, double time_step) {
  Case c = soft_case(xi_con);
  c.materials[0].youngs_modulus = 1e8;
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  for (int k = 0; k < count; ++k) {
    ParticleSpec p;
    p.radius = 1e-3;
    p.position = Eigen::Vector3d(0.004 + 0.0021 * k, 0.005, 1e-3);
    c.particles.push_back(p);
  }
  c.boundaries.push_back(
      plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0, "floor"));
  Domain d;
  d.min = Eigen::Vector3d(0.0, 0.0, -0.002);
  d.max = Eigen::Vector3d(0.05, 0.01, 0.01);
  d.periodic = {false, true, false};
  c.domain = d;
  c.time_step = time_step;
  return c;
}

/// A random polydisperse gas (radii uniform in [r_min, r_max]) in box [0, L]^3 with random
/// velocities of magnitude up to @p speed, seeded.
inline void add_random_gas(Case& c, std::size_t count, double r_min, double r_max, double length,
                           double speed, std::uint64_t seed) {
  FillRequest request;
  request.region = Box{Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(length)};
  request.radius.kind = RadiusDistribution::Kind::kUniform;
  request.radius.min = r_min;
  request.radius.max = r_max;
  request.count = count;
  request.seed = seed;
  std::vector<ParticleSpec> gas = insert_random_fill(request, c.particles);
  Rng rng(seed + 1);
  for (ParticleSpec& p : gas) {
    p.velocity = speed *
                 Eigen::Vector3d(2.0 * uniform01(rng) - 1.0, 2.0 * uniform01(rng) - 1.0,
                                 2.0 * uniform01(rng) - 1.0) /
                 std::sqrt(3.0);
    c.particles.push_back(p);
  }
  Domain d;
  d.max = Eigen::Vector3d::Constant(length);
  c.domain = d;
}

}  // namespace bondem::testing
