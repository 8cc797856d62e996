#pragma once
/// @file insertion.hpp
/// Particle insertion for packing cases: a regular lattice and a seeded random fill of a box.
///
/// Pure functions: they return particle specs (solver/setup/case.hpp) and never touch a scene, so a
/// case reader or a test can call them directly. Everything random is drawn from one
/// std::mt19937_64 stream with hand-written mappings (uniform, Box-Muller), because the standard
/// library distributions are implementation-defined and would give different packings on
/// different standard libraries.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/box.hpp"
#include "geometry/domain.hpp"
#include "solver/setup/case.hpp"
#include "solver/setup/radius_distribution.hpp"

namespace bondem {

/// The random engine of insertion; its output sequence is fixed by the C++ standard.
using Rng = std::mt19937_64;

/// A target that random sequential addition cannot reach (too dense, or too few attempts).
class InsertionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What the D-values of a particle-size measurement count: the number of particles (image
/// analysis, counting) or their volume, i.e. mass (sieving, laser diffraction).
enum class SizeWeighting { kNumber, kVolume };

/// Log-normal radius distribution from the diameters D10 < D50 < D90 of a size measurement
/// (D50: half of the particles, by @p weighting, are smaller). σ = ln(D90/D10) / (2 z_0.9) is the
/// same for both weightings; the radii drawn are counted by number, so volume-weighted values
/// are converted by Hatch-Choate: ln(median by number) = ln(D50 by volume) - 3σ². No cut-offs.
/// Throws std::invalid_argument unless 0 < d10 < d50 < d90, all finite.
RadiusDistribution lognormal_from_d_values(double d10, double d50, double d90,
                                           SizeWeighting weighting);

/// Uniform double in [0, 1) from the top 53 bits of one engine output (exact on every platform).
double uniform01(Rng& rng);

/// Standard normal deviate by Box-Muller (cosine branch only; uses two engine outputs).
double standard_normal(Rng& rng);

/// Throw std::invalid_argument unless @p distribution has consistent, positive parameters.
void validate(const RadiusDistribution& distribution);

/// One radius of @p distribution, redrawn until inside the cut-offs. Throws std::invalid_argument
/// for an invalid distribution or cut-offs that reject 10000 draws in a row.
double draw_radius(const RadiusDistribution& distribution, Rng& rng);

/// Most particles one insertion may create: a lattice or a random-fill count beyond it is refused
/// before anything is allocated (a few hundred bytes per particle in a run: 10^8 is tens of GB).
inline constexpr double kMaxInsertedParticles = 1e8;

/// Particles per axis of insert_lattice(), counted in double so that no count can overflow.
/// Throws std::invalid_argument as insert_lattice() does for invalid arguments.
std::array<double, 3> lattice_counts(const Box& region, double spacing, double radius);

/// Simple-cubic lattice of particles of one radius filling the region: centers at
/// min + radius + k*spacing while the sphere fits. Returns specs with the given material index and
/// zero velocity, x varying fastest, then y, then z.
///
/// A spacing below 2*radius is allowed on purpose: it starts neighbors overlapped (e.g. at the
/// bond's equilibrium overlap). Throws std::invalid_argument for a degenerate box, non-positive
/// radius or spacing, a negative material, a sphere that does not fit the region, or more than
/// kMaxInsertedParticles particles.
std::vector<ParticleSpec> insert_lattice(const Box& region, double spacing, double radius,
                                         int material);

/// The lattice of insert_lattice() as a block that stores no particle (solver/setup/
/// particle_list.hpp): its sphere k is insert_lattice()'s k-th, bit for bit. Throws as
/// insert_lattice() does.
LatticeBlock lattice_block(const Box& region, double spacing, double radius, int material);

/// Random sequential addition cannot go beyond about 0.30-0.38 solid fraction (0.38 monodisperse
/// in bulk, lower next to walls): targets above this are refused rather than attempted.
inline constexpr double kMaxRandomFillSolidFraction = 0.40;

/// What insert_random_fill() should produce. Exactly one of `count` and `solid_fraction` is > 0.
struct FillRequest {
  Box region;        ///< every inserted sphere lies fully inside
  int material = 0;  ///< material index of every inserted particle
  RadiusDistribution radius;
  std::size_t count = 0;        ///< target: this many particles
  double solid_fraction = 0.0;  ///< target: inserted sphere volume / region volume, in (0, 1)
  std::uint64_t seed = 1;       ///< same seed, same particles, bit for bit
  std::size_t max_attempts_per_particle = 1000;        ///< random positions tried before giving up
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< initial velocity of every particle
};

/// Seeded random sequential addition into a box.
///
/// Draws all radii first (for `solid_fraction`, until the drawn volume reaches
/// solid_fraction * region volume, so the result exceeds the target by less than one particle),
/// sorts them largest first (big spheres are hard to fit into a crowded box, so RSA then gets
/// denser), then places each at uniformly random positions fully inside the region until it
/// overlaps neither a particle placed before nor one of @p existing (touching is allowed).
/// Overlap checks use a uniform cell grid, so the cost is O(N * attempts), not O(N^2).
///
/// `solid_fraction` counts only this request's particles; @p existing particles inside the region
/// make it harder to reach. The output is in placement order (radius descending).
///
/// Throws std::invalid_argument for invalid requests (a count above kMaxInsertedParticles among
/// them) and InsertionError, with target, reached count and solid fraction and attempts, when the
/// target is above kMaxRandomFillSolidFraction or a particle finds no free position: for denser
/// packings, pour and settle under gravity. A count whose smallest possible spheres already
/// exceed kMaxRandomFillSolidFraction is refused before any radius is drawn, and drawing stops
/// as soon as the drawn volume passes it, so an impossible count costs neither time nor memory.
std::vector<ParticleSpec> insert_random_fill(const FillRequest& request,
                                             const ParticleList& existing = {});

/// Two initial particles that overlap by more than a run allows.
struct InitialOverlap {
  std::size_t later = 0;         ///< index of the later particle of the pair
  std::size_t earlier = 0;       ///< index of the earlier one
  double fraction = 0.0;         ///< overlap / smaller radius
  bool across_boundary = false;  ///< the overlap is with a periodic image
};

/// The overlap of @p particles deeper than @p max_fraction of the smaller radius (what makes a
/// run stop at its first step) with the smallest `later`, then the smallest `earlier`, or none.
/// With a @p domain, its periodic axes wrap (nearest image; exact for axes longer than four
/// radii). A uniform cell grid of about one cell per particle keeps it O(N).
std::optional<InitialOverlap> find_initial_overlap(const ParticleList& particles,
                                                   const Domain* domain, double max_fraction);

}  // namespace bondem
