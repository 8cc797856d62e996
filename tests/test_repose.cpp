// The dynamic angle of repose of a drum's bed (solver/analysis/repose): synthetic beds whose
// surface is a known inclined line in the drum's cross-section.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "solver/analysis/repose.hpp"

namespace bondem {
namespace {

using Eigen::Vector3d;

constexpr double kDrumRadius = 5.0e-3;  // [m]
constexpr double kPi = std::numbers::pi;

double radians(double degrees) {
  return degrees * kPi / 180.0;
}

// Particles as the four arrays the analysis takes.
struct Bed {
  std::vector<double> x, y, z, radius;
  // A particle of radius r at chord position u and height h in the cross-section of a drum whose
  // axis is the line through @p centre along @p axis (horizontal): the centre is
  // centre + u (axis x e_z) + h e_z.
  void add(double u, double h, double r, const Vector3d& centre, const Vector3d& axis) {
    const Vector3d chord = axis.cross(Vector3d::UnitZ());
    const Vector3d p = centre + u * chord + h * Vector3d::UnitZ();
    x.push_back(p.x());
    y.push_back(p.y());
    z.push_back(p.z());
    radius.push_back(r);
  }
  [[nodiscard]] ReposeAngle angle(const Vector3d& centre, const Vector3d& axis) const {
    return dynamic_repose_angle(x, y, z, radius, axis, centre, kDrumRadius);
  }
};

// Spheres of radius r in layers parallel to the line through the drum's centre at angle @p theta
// (rising towards +chord for theta > 0), on a square lattice of spacing 2r aligned with the line,
// filling the drum below it. The top layer's centres lie on the line, so every surface point of
// the fit is a top-layer sphere: in a bin, the top-layer sphere nearest the bin's uphill end is at
// most 2r sin(theta) below the line's height there, and any lower layer at least 2r / cos(theta)
// >= 2r sin(theta) below it. (The top layer has a sphere in every bin: its spacing along the
// chord, 2r cos(theta), is below the bin width 0.06 R.)
Bed layered_bed(double theta, double r, const Vector3d& centre, const Vector3d& axis) {
  Bed bed;
  const double d = 2.0 * r;
  const int n = static_cast<int>(kDrumRadius / d) + 1;
  for (int i = -n; i <= n; ++i)
    for (int j = 0; j <= 2 * n; ++j) {
      const double u = i * d * std::cos(theta) + j * d * std::sin(theta);
      const double h = i * d * std::sin(theta) - j * d * std::cos(theta);
      if (u * u + h * h <= (kDrumRadius - r) * (kDrumRadius - r)) bed.add(u, h, r, centre, axis);
    }
  return bed;
}

TEST(ReposeAngle, LayersOnAnInclinedLineGiveItsAngleToRoundOff) {
  const Vector3d axis = Vector3d::UnitY();
  const Vector3d centre(0.01, -0.02, 0.03);
  for (const double degrees : {0.0, 30.0, 45.0}) {
    const Bed bed = layered_bed(radians(degrees), 1.0e-4, centre, axis);
    const ReposeAngle a = bed.angle(centre, axis);
    // The surface points are on the line to a few ulps of the drum's position (3e-2 m), 1e-17 m
    // over a fitted span of 6e-3 m: the slope holds to about 1e-14, the angle far below 1e-9 deg.
    EXPECT_EQ(a.bins_used, 20) << degrees;
    EXPECT_NEAR(a.degrees, degrees, 1.0e-9) << degrees;
    EXPECT_NEAR(a.slope, std::tan(radians(degrees)), 1.0e-12) << degrees;
    EXPECT_LT(a.residual, 1.0e-12 * kDrumRadius) << degrees;
  }
}

// A bed on the axis-aligned square lattice (spacing d = 2r) below the line h = tan(theta) u + b:
// in each bin the highest centre is within d below the line, e_k in (-d, 0]. The least-squares
// slope is off by sum (u_k - mean u)(e_k + d/2) / sum (u_k - mean u)^2, at most
// (d / 2) sum |u_k - mean u| / sum (u_k - mean u)^2. With one point in each of the 20 bins of
// width w (0.06 R), spread like the bin centres, the ratio is 100 w / (665 w^2) = 0.150 / w;
// points anywhere in their bins move it by less than half: bound (d / 2) 0.23 / w. The angle is
// off by at most cos^2(theta) times that (d atan(s) / ds). The residual is at most d / 2: the
// true line shifted down by d / 2 already leaves no more, and least squares does no worse.
TEST(ReposeAngle, LatticeBelowAnInclinedLineGivesItsAngleWithinTheBinningError) {
  const Vector3d axis = Vector3d::UnitY();
  const Vector3d centre = Vector3d::Zero();
  const double r = 2.0e-5;
  const double d = 2.0 * r;
  const double bin_width = 0.06 * kDrumRadius;
  const int n = static_cast<int>(kDrumRadius / d) + 1;
  for (const double degrees : {0.0, 12.0, 30.0}) {
    const double slope = std::tan(radians(degrees));
    Bed bed;
    for (int i = -n; i <= n; ++i)
      for (int j = -n; j <= n; ++j) {
        const double u = i * d;
        const double h = j * d;
        // b = 0.3 d keeps the line off the lattice points at theta = 0.
        if (h <= slope * u + 0.3 * d && u * u + h * h <= (kDrumRadius - r) * (kDrumRadius - r))
          bed.add(u, h, r, centre, axis);
      }
    const ReposeAngle a = bed.angle(centre, axis);
    const double slope_bound = 0.5 * d * 0.23 / bin_width;
    const double cos_theta = std::cos(radians(degrees));
    EXPECT_EQ(a.bins_used, 20) << degrees;
    EXPECT_NEAR(a.slope, slope, slope_bound) << degrees;
    EXPECT_NEAR(a.degrees, degrees, cos_theta * cos_theta * slope_bound * 180.0 / kPi) << degrees;
    EXPECT_LE(a.residual, 0.5 * d) << degrees;
  }
}

TEST(ReposeAngle, MirroredBedGivesTheOppositeSlope) {
  const Vector3d axis = Vector3d::UnitY();
  const Vector3d centre = Vector3d::Zero();
  const Bed bed = layered_bed(radians(30.0), 1.0e-4, centre, axis);
  Bed mirrored = bed;
  for (double& x : mirrored.x) x = -x;
  const ReposeAngle a = bed.angle(centre, axis);
  const ReposeAngle b = mirrored.angle(centre, axis);
  EXPECT_GT(a.slope, 0.0);
  EXPECT_LT(b.slope, 0.0);
  EXPECT_NEAR(b.slope, -a.slope, 1.0e-12);
  EXPECT_NEAR(b.degrees, a.degrees, 1.0e-9);
}

// The chord runs along axis x e_z: for the axis -y it is -x, so the same particles give the
// opposite slope; for the axis +x it is -y, and the bed laid out along -y gives the same slope as
// along +x for the axis +y.
TEST(ReposeAngle, ChordDirectionFollowsTheAxis) {
  const Vector3d centre(0.0, 0.0, 0.0);
  const Bed bed = layered_bed(radians(30.0), 1.0e-4, centre, Vector3d::UnitY());
  const ReposeAngle along_y = bed.angle(centre, Vector3d::UnitY());
  const ReposeAngle against_y = bed.angle(centre, -Vector3d::UnitY());
  EXPECT_NEAR(along_y.slope, std::tan(radians(30.0)), 1.0e-12);
  EXPECT_NEAR(against_y.slope, -along_y.slope, 1.0e-12);

  const Bed across = layered_bed(radians(30.0), 1.0e-4, centre, Vector3d::UnitX());
  const ReposeAngle along_x = across.angle(centre, Vector3d::UnitX());
  EXPECT_NEAR(along_x.slope, along_y.slope, 1.0e-12);
  EXPECT_NEAR(along_x.degrees, 30.0, 1.0e-9);
}

// Particles near the walls (outside the central 60 %) and particles outside the drum (escaped)
// do not count, and the order of the particles does not matter: results are bit-identical.
TEST(ReposeAngle, WallRegionEscapedParticlesAndOrderDoNotCount) {
  const Vector3d axis = Vector3d::UnitY();
  const Vector3d centre(0.0, 0.0, 0.0);
  const Bed bed = layered_bed(radians(30.0), 1.0e-4, centre, axis);
  Bed with_strays = bed;
  with_strays.add(0.65 * kDrumRadius, 0.70 * kDrumRadius, 1.0e-4, centre, axis);  // near the wall
  with_strays.add(0.0, 1.2 * kDrumRadius, 1.0e-4, centre, axis);                  // outside
  const ReposeAngle a = bed.angle(centre, axis);
  const ReposeAngle b = with_strays.angle(centre, axis);
  EXPECT_EQ(b.slope, a.slope);
  EXPECT_EQ(b.bins_used, a.bins_used);
  EXPECT_EQ(b.residual, a.residual);

  Bed reversed = bed;
  std::reverse(reversed.x.begin(), reversed.x.end());
  std::reverse(reversed.y.begin(), reversed.y.end());
  std::reverse(reversed.z.begin(), reversed.z.end());
  std::reverse(reversed.radius.begin(), reversed.radius.end());
  const ReposeAngle c = reversed.angle(centre, axis);
  EXPECT_EQ(c.slope, a.slope);
  EXPECT_EQ(c.residual, a.residual);
}

TEST(ReposeAngle, FewerThanThreeBinsGiveNaN) {
  const Vector3d axis = Vector3d::UnitY();
  const Vector3d centre = Vector3d::Zero();
  const ReposeAngle empty = Bed{}.angle(centre, axis);
  EXPECT_EQ(empty.bins_used, 0);
  EXPECT_TRUE(std::isnan(empty.degrees));
  EXPECT_TRUE(std::isnan(empty.slope));
  EXPECT_TRUE(std::isnan(empty.residual));

  Bed two;  // two bins, however many particles
  for (const double u : {-2.0e-3, -1.95e-3, 2.0e-3}) two.add(u, 0.0, 1.0e-4, centre, axis);
  const ReposeAngle a = two.angle(centre, axis);
  EXPECT_EQ(a.bins_used, 2);
  EXPECT_TRUE(std::isnan(a.degrees));

  Bed three;  // three bins: a fit through three collinear points, tops on h = -u + r
  for (const double u : {-2.0e-3, 0.0, 2.0e-3}) three.add(u, -u, 1.0e-4, centre, axis);
  const ReposeAngle c = three.angle(centre, axis);
  EXPECT_EQ(c.bins_used, 3);
  EXPECT_NEAR(c.slope, -1.0, 1.0e-12);
  EXPECT_NEAR(c.degrees, 45.0, 1.0e-9);
}

TEST(ReposeAngle, RefusesBadInput) {
  const std::vector<double> one{0.0};
  const std::vector<double> none;
  const Vector3d centre = Vector3d::Zero();
  const Vector3d y = Vector3d::UnitY();
  EXPECT_THROW(dynamic_repose_angle(one, one, one, none, y, centre, kDrumRadius),
               std::invalid_argument);
  EXPECT_THROW(dynamic_repose_angle(one, one, one, one, Vector3d::UnitZ(), centre, kDrumRadius),
               std::invalid_argument);  // a vertical axis has no horizontal chord
  EXPECT_THROW(dynamic_repose_angle(one, one, one, one, 2.0 * y, centre, kDrumRadius),
               std::invalid_argument);
  EXPECT_THROW(dynamic_repose_angle(one, one, one, one, y, centre, 0.0), std::invalid_argument);
  EXPECT_THROW(dynamic_repose_angle(one, one, one, one, y, centre, kDrumRadius, {0, 0.6}),
               std::invalid_argument);
  EXPECT_THROW(dynamic_repose_angle(one, one, one, one, y, centre, kDrumRadius, {20, 1.5}),
               std::invalid_argument);
}

}  // namespace
}  // namespace bondem
