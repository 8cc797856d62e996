#pragma once
/// @file repose.hpp
/// The dynamic angle of repose of the bed in a rotating drum, from a particle state. A pure
/// function: no I/O, no state, no threads.
///
/// Method: the free surface of a bed rolling in a drum is a nearly straight line in the drum's
/// cross-section, and its inclination to the horizontal is the dynamic angle of repose (Mellmann
/// 2001, Powder Technol. 118:251-270, the rolling regime). DEM studies measure it by fitting a line
/// to the bed surface in the cross-section (e.g. Yang, Zou & Yu 2003, Powder Technol. 130:138-146).
/// Here: centres are projected onto the cross-section; the horizontal chord through the drum
/// centre is cut into bins over its central part (by default 20 bins over the central 60 % of the
/// diameter, clear of the walls, where the surface curves into the toe and shoulder); in each bin
/// the highest particle top (centre height + radius) is a surface point, at that particle's
/// position along the chord; a straight line through these points by least squares gives the
/// slope, and the angle is atan(|slope|). Gravity is along -z.

#include <Eigen/Core>
#include <span>

namespace bondem {

/// The inclination of a drum's bed surface.
struct ReposeAngle {
  /// atan(|slope|) in degrees, in [0, 90); NaN when fewer than 3 bins hold a particle.
  double degrees;
  /// d(height)/d(chord) of the fitted surface line; the chord direction is axis x e_z (+x for the
  /// axis +y). Positive: the bed is higher on the +chord side. A drum turning in the positive
  /// sense about its axis carries the bed up on the -chord side (negative slope). NaN with
  /// degrees.
  double slope;
  int bins_used;  ///< bins holding at least one particle (the points of the fit)
  /// RMS vertical distance of the surface points from the line [length unit of the input]; NaN
  /// with degrees.
  double residual;
};

/// How the drum's cross-section is cut for the surface fit.
struct ReposeBinning {
  int bins = 20;                  ///< bins along the chord
  double central_fraction = 0.6;  ///< part of the diameter binned, centred on the axis
};

/// The dynamic angle of repose of particles (centres @p x, @p y, @p z, radii @p radius [m]) in a
/// drum of inner radius @p drum_radius [m] whose axis is the line through @p drum_centre along
/// the unit vector @p axis. The axis must be horizontal (|axis . e_z| <= 1e-9; any direction in
/// the x-y plane, e.g. +y or -y). Particles whose centre lies farther than @p drum_radius from
/// the axis (escaped ones) and particles outside the binned band are left out. Of equal tops in a
/// bin the one nearest the -chord end counts and sums run in bin order, so the result does not
/// depend on the order of the particles.
/// @throws std::invalid_argument for spans of unequal length, a non-unit or non-horizontal axis,
///         a drum radius that is not positive, fewer than 1 bin or a central fraction outside
///         (0, 1].
ReposeAngle dynamic_repose_angle(std::span<const double> x, std::span<const double> y,
                                 std::span<const double> z, std::span<const double> radius,
                                 const Eigen::Vector3d& axis, const Eigen::Vector3d& drum_centre,
                                 double drum_radius, const ReposeBinning& binning = {});

}  // namespace bondem
