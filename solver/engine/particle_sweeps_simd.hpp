#pragma once
/// @file particle_sweeps_simd.hpp
/// The stepper's two sweeps over the particles (velocity Verlet's half-kicks and drift) in SIMD
/// lanes of the target select_simd_target chose, one particle per lane. Each value takes the
/// same IEEE operations in the same order on every target, scalar included, so the bytes are
/// the same everywhere. 1/m and 1/I are computed in each sweep rather than stored (16 B per
/// particle); in lanes those four divisions per particle-step run several at a time, where the
/// scalar loops waited on the divider.

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace bondem {

/// The particle arrays the sweeps read and write, for particles by index.
struct SweepArrays {
  double *x, *y, *z;
  double *vx, *vy, *vz;
  const double *fx, *fy, *fz;
  double *wx, *wy, *wz;        ///< angular velocity: null where the run has no friction
  const double *tx, *ty, *tz;  ///< torque: null with wx
  double *dx, *dy, *dz;        ///< displacement since insertion: null where not tracked
  const double *mass, *radius;
  const double *x0, *y0, *z0;   ///< positions at the neighbor list's last build
  const std::uint8_t* counted;  ///< 1 where the particle's displacement counts; null: all do
  /// Where non-null, the opening sweep also writes each particle's new (x, y, z, r) at
  /// records + 4 i and (vx, vy, vz, m) at records + 4 record_count + 4 i: the pair pass's
  /// kinematics records (LanePassScratch), written while the values are in registers.
  double* records = nullptr;
  std::size_t record_count = 0;  ///< the particles the records hold
  /// Where non-null (with wx), the opening sweep also writes each particle's new (wx, wy, wz, 0)
  /// at spin_records + 4 i (records_hold_spins).
  double* spin_records = nullptr;
};

/// The opening sweep over particles [@p first, @p end): v += (dt/2) F/m, x += dt v (the tracked
/// displacement by the same step), w += (dt/2) T/I with I = 0.4 m r^2. Returns the largest
/// squared displacement since the list's last build among the counted particles (0 if none).
double opening_sweep(const SweepArrays& a, double dt, std::size_t first, std::size_t end);

/// The closing sweep over particles [@p first, @p end): w += (dt/2) T/I, v += (dt/2) F/m.
/// Returns whether every position and velocity is finite (their sum, as one test).
bool closing_sweep(const SweepArrays& a, double dt, std::size_t first, std::size_t end);

/// What closing_opening_sweep() saw.
struct SweepResult {
  double largest_sq = 0.0;  ///< as opening_sweep() returns
  bool finite = true;       ///< as closing_sweep() returns, for the step it closes

  /// Adds what another range's sweep saw (exact: any order agrees).
  void merge(const SweepResult& part) {
    largest_sq = std::max(largest_sq, part.largest_sq);
    finite = finite && part.finite;
  }
};

/// closing_sweep() of the step before, then opening_sweep(), over particles [@p first, @p end)
/// in one pass: the same operations, so the same bytes, with each array read and written once
/// instead of twice. For a step whose end state nobody reads (Stepper::drift_ahead).
SweepResult closing_opening_sweep(const SweepArrays& a, double dt, std::size_t first,
                                  std::size_t end);

}  // namespace bondem
