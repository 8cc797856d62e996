#pragma once
// The two-particle case of the linear ("hooke") law tests.
#include <string>

namespace bondem::testing {

/// Two 1 mm spheres of 2000 kg/m^3 (m* = 4.19e-6 kg) with k = 1e4 N/m: omega_0 = 4.886e4 rad/s,
/// t_c = pi / omega_0 = 64.3 us, 129 steps of 0.5 us. E = 1e8 Pa keeps 0.2 T_Rayleigh (4.5 us)
/// above t_c / 50 (1.29 us), so the contact sets the time-step limit.
inline const std::string kHookeCase = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e8, poisson_ratio: 0.0}
contact:
  normal_law: hooke
  stiffness: 1.0e4
  damping_ratio: 0.0
time: {step: 5.0e-7, end: 0.001}
particles:
  - {material: powder, radius: 0.001, position: [0, 0, 0], velocity: [0.5, 0, 0]}
  - {material: powder, radius: 0.001, position: [0.0025, 0, 0], velocity: [-0.5, 0, 0]}
output:
  directory: out
)";

}  // namespace bondem::testing
