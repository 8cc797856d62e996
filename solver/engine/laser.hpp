#pragma once
/// @file laser.hpp
/// A moving Gaussian laser over a particle bed (powder-bed fusion). The beam travels along -z
/// (light comes from above); its spot on the x-y plane follows a path of straight segments.
/// Deterministic and single-threaded: the deposit is cheap next to the contact loop.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace bondem {

/// One straight stretch of the scan path, traversed from start to end.
struct LaserSegment {
  Eigen::Vector2d start;  ///< x-y position where the segment begins [m]
  Eigen::Vector2d end;    ///< x-y position where it ends [m]
  double speed;           ///< scan speed [m/s], > 0
};

/// A Gaussian beam of 1/e^2 radius w: intensity I(r) = 2 P / (pi w^2) exp(-2 r^2 / w^2).
/// Segments run one after another from start_time; a jump from one segment's end to the next
/// one's start takes no time. The beam is off before start_time and from laser_end_time on.
struct Laser {
  double power;           ///< P [W]
  double spot_radius;     ///< w, the 1/e^2 intensity radius [m]
  double absorptivity;    ///< fraction of the incident power absorbed where it lands, in [0, 1]
  double start_time = 0;  ///< when the first segment starts [s]
  std::vector<LaserSegment> path;
};

/// Where the beam is at @p time, or nullopt while it is off. Each segment occupies the half-open
/// interval [t_k, t_k + |end - start| / speed), so the beam is off at exactly laser_end_time.
/// @throws std::invalid_argument if a segment's speed is not a finite positive number.
std::optional<Eigen::Vector2d> beam_centre(const Laser& laser, double time);

/// The time the last segment ends: start_time + sum of |end - start| / speed [s].
/// @throws std::invalid_argument if a segment's speed is not a finite positive number.
double laser_end_time(const Laser& laser);

/// Exact fraction of the power of a Gaussian beam centred at @p centre (1/e^2 radius @p w) that
/// falls on the rectangle [x0, x1] x [y0, y1]:
/// 1/4 [erf(sqrt2 (x1 - xc) / w) - erf(sqrt2 (x0 - xc) / w)] [the same in y].
double beam_fraction(const Eigen::Vector2d& centre, double w, double x0, double x1, double y0,
                     double y1);

/// Periods of the bed along x and y [m]; 0 on an axis that is not periodic. On a periodic axis
/// the particles' images one or more periods away are seen by the beam too, so power that falls
/// across a periodic boundary lands on the particles at the other side instead of being missed.
struct LaserPeriods {
  double x = 0;
  double y = 0;
};

/// Totals of one deposit [W].
struct LaserDeposit {
  double absorbed = 0;  ///< absorbed by particles
  double missed = 0;    ///< absorptivity x power that fell between particles (on the substrate)
};

/// Add to heat_rate[i] the laser power absorbed by each of the @p n particles at @p time [W].
///
/// The beam is cut to a square window of half-width 3 w around its centre (the power outside is
/// 1 - erf(3 sqrt2)^2 ~ 4e-9 of P, well below 1e-7, and is dropped). The window is tiled by
/// square columns of side at most min(w / 8, r_min / 3), r_min the smallest radius among particles
/// that reach into it, and by at most 512 x 512 columns (the side grows if needed). Each column
/// belongs to the particle whose sphere surface is highest above the column centre (z +
/// sqrt(r^2 - d^2) for a horizontal distance d < r; ties go to the smaller index) and that owner
/// receives absorptivity x P x the beam fraction on the column; a column over no particle adds
/// its share to `missed`. So absorbed + missed = absorptivity x P x (fraction in the window) to
/// rounding. Shadowing is geometric only: no reflection, no transmission, no beam divergence.
/// With the beam off nothing is added and both totals are 0. The result depends on nothing but
/// the inputs (no threads); particles with radius <= 0 are ignored. With @p periods set, a
/// particle is a candidate once per image whose disc reaches into the window.
/// @throws std::invalid_argument for a spot radius that is not finite and positive, a negative or
///         non-finite power, an absorptivity outside [0, 1], or a bad segment speed.
LaserDeposit deposit_laser_heat(const double* x, const double* y, const double* z,
                                const double* radius, std::size_t n, const Laser& laser,
                                double time, double* heat_rate, LaserPeriods periods = {});

/// Buffers deposit_laser_heat reuses between calls (a run deposits every step).
struct LaserScratch {
  /// A particle image inside the window: its index and centre relative to the beam centre.
  struct Candidate {
    std::size_t index;
    double px;
    double py;
  };
  std::vector<Candidate> candidates;
  std::vector<double> top;
  std::vector<std::size_t> owner;
  std::vector<double> gained;
};

/// How the processes of a distributed run, each holding some of the particles, agree on one
/// deposit: what every process must see the same (set by the run; no MPI here).
struct LaserAgreement {
  /// Replaces @p r_min, this process's smallest radius in the window, by every process's.
  std::function<void(double& r_min)> smallest_radius;
  /// Replaces each column's @p top (this process's highest surface, -inf for none) and @p id (its
  /// particle's id) by the highest over every process, equal tops going to the smaller id.
  std::function<void(std::vector<double>& top, std::vector<std::int64_t>& id)> highest_tops;
};

/// deposit_laser_heat with caller-owned buffers: the same result without per-call allocation.
/// With particle ids @p id, a column whose tops are equal goes to the smaller id instead of the
/// smaller index, so that the deposit does not depend on the order the particles are stored in.
/// With @p counted (one flag per particle) and @p agreement (both, or neither), only the counted
/// particles take part here and the processes agree on the columns: each process's counted
/// particles get what they get when one process deposits on every particle, and every process
/// returns the same totals (a distributed run; ids required).
LaserDeposit deposit_laser_heat(const double* x, const double* y, const double* z,
                                const double* radius, const std::int64_t* id, std::size_t n,
                                const Laser& laser, double time, double* heat_rate,
                                LaserScratch& scratch, LaserPeriods periods = {},
                                const std::uint8_t* counted = nullptr,
                                const LaserAgreement* agreement = nullptr);

}  // namespace bondem
