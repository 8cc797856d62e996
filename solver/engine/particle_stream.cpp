#include "solver/engine/particle_stream.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "solver/engine/scene.hpp"
#include "solver/models/heat_law.hpp"
#include "solver/setup/insertion.hpp"

namespace bondem {
namespace {

/// SplitMix64's finaliser: consecutive inputs give unrelated outputs.
std::uint64_t mix(std::uint64_t value) {
  value += 0x9e3779b97f4a7c15ULL;
  value = (value ^ (value >> 30U)) * 0xbf58476d1ce4e5b9ULL;
  value = (value ^ (value >> 27U)) * 0x94d049bb133111ebULL;
  return value ^ (value >> 31U);
}

/// Generator of one stream's draws for @p purpose (radius or centres), particle and step.
Rng keyed_rng(const ParticleStream& stream, std::size_t stream_index, std::uint64_t purpose,
              std::int64_t n, std::int64_t step) {
  std::uint64_t key = mix(stream.spec.seed);
  for (const std::uint64_t part :
       {static_cast<std::uint64_t>(stream_index), purpose, static_cast<std::uint64_t>(n),
        static_cast<std::uint64_t>(step)}) {
    key = mix(key ^ part);
  }
  return Rng(key);
}

constexpr std::uint64_t kRadiusDraws = 1;
constexpr std::uint64_t kCentreDraws = 2;

/// The particles near a stream's region on a uniform grid of cells at least two largest radii
/// wide, in coordinates where periodic images are resolved: an axis on which the region and its
/// reach wrap around the domain is binned around the whole domain (cells wrap), any other
/// periodic axis takes each centre's image nearest the region.
class RegionGrid {
 public:
  RegionGrid(const Box& region, double reach, const Domain& domain, const Particles& p) {
    double cell = 2.0 * reach;
    for (int a = 0; a < 3; ++a) {
      lo_[a] = region.min[a] - 2.0 * reach;
      hi_[a] = region.max[a] + 2.0 * reach;
      length_[a] = domain.max[a] - domain.min[a];
      periodic_[a] = domain.periodic[a];
      wraps_[a] = periodic_[a] && hi_[a] - lo_[a] >= length_[a] - 2.0 * cell;
      if (wraps_[a]) {
        lo_[a] = domain.min[a];
        hi_[a] = domain.max[a];
      }
    }
    // Select the particles within reach and their local coordinates.
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Eigen::Vector3d u = local({p.x[i], p.y[i], p.z[i]});
      bool near = true;
      for (int a = 0; a < 3 && near; ++a) near = wraps_[a] || (u[a] >= lo_[a] && u[a] <= hi_[a]);
      if (!near) continue;
      centre_.push_back(u);
      radius_.push_back(p.radius[i]);
      selected_.push_back(static_cast<std::uint32_t>(i));
    }
    // Coarser cells when the grid would outnumber its particles many times over.
    const double budget = 8.0 * static_cast<double>(centre_.size()) + 64.0;
    for (;;) {
      double cells = 1.0;
      for (int a = 0; a < 3; ++a) cells *= std::max(1.0, std::floor((hi_[a] - lo_[a]) / cell));
      if (cells <= budget) break;
      cell *= 2.0;
    }
    std::size_t total = 1;
    for (int a = 0; a < 3; ++a) {
      count_[a] = static_cast<int>(std::max(1.0, std::floor((hi_[a] - lo_[a]) / cell)));
      width_[a] = (hi_[a] - lo_[a]) / count_[a];
      total *= static_cast<std::size_t>(count_[a]);
    }
    // Counting sort of the particles by cell.
    std::vector<std::size_t> cell_of(centre_.size());
    begin_.assign(total + 1, 0);
    for (std::size_t k = 0; k < centre_.size(); ++k) {
      cell_of[k] = flat(cell_index(centre_[k]));
      ++begin_[cell_of[k] + 1];
    }
    for (std::size_t c = 0; c < total; ++c) begin_[c + 1] += begin_[c];
    members_.resize(centre_.size());
    std::vector<std::size_t> next(begin_.begin(), begin_.end() - 1);
    for (std::size_t k = 0; k < centre_.size(); ++k) members_[next[cell_of[k]]++] = k;
  }

  /// The particles within reach, by index, in the order given.
  const std::vector<std::uint32_t>& selected() const { return selected_; }

  /// Whether a sphere at @p centre (local coordinates) of radius @p r overlaps a particle.
  bool overlaps(const Eigen::Vector3d& centre, double r) const {
    const std::array<int, 3> home = cell_index(centre);
    std::array<std::array<int, 3>, 3> around{};
    std::array<int, 3> span{};
    for (int a = 0; a < 3; ++a) {
      // Up to three distinct cells per axis: wrapped on wrapping axes, clipped on others.
      for (int d = -1; d <= 1; ++d) {
        int c = home[a] + d;
        if (wraps_[a]) {
          c = (c % count_[a] + count_[a]) % count_[a];
        } else if (c < 0 || c >= count_[a]) {
          continue;
        }
        if (std::find(around[a].begin(), around[a].begin() + span[a], c) ==
            around[a].begin() + span[a]) {
          around[a][span[a]++] = c;
        }
      }
    }
    for (int ix = 0; ix < span[0]; ++ix) {
      for (int iy = 0; iy < span[1]; ++iy) {
        for (int iz = 0; iz < span[2]; ++iz) {
          const std::size_t c = flat({around[0][ix], around[1][iy], around[2][iz]});
          for (std::size_t m = begin_[c]; m < begin_[c + 1]; ++m) {
            const std::size_t k = members_[m];
            if (apart(centre, r, centre_[k], radius_[k])) continue;
            return true;
          }
        }
      }
    }
    return false;
  }

  /// Whether spheres at @p a and @p b (local coordinates) do not overlap (touching allowed).
  bool apart(const Eigen::Vector3d& a, double ra, const Eigen::Vector3d& b, double rb) const {
    Eigen::Vector3d d = a - b;
    for (int axis = 0; axis < 3; ++axis) {
      if (wraps_[axis]) d[axis] -= length_[axis] * std::round(d[axis] / length_[axis]);
    }
    const double reach = ra + rb;
    return d.squaredNorm() >= reach * reach;
  }

  /// Local coordinates of a position: wrapped into the domain on wrapping axes, the image
  /// nearest the grid's middle on other periodic axes.
  Eigen::Vector3d local(const Eigen::Vector3d& x) const {
    Eigen::Vector3d u = x;
    for (int a = 0; a < 3; ++a) {
      if (!periodic_[a]) continue;
      if (wraps_[a]) {
        u[a] = wrap_periodic(x[a], lo_[a], length_[a]);
      } else {
        const double middle = 0.5 * (lo_[a] + hi_[a]);
        u[a] = x[a] - length_[a] * std::round((x[a] - middle) / length_[a]);
      }
    }
    return u;
  }

 private:
  std::array<int, 3> cell_index(const Eigen::Vector3d& u) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) {
      const double t = std::floor((u[a] - lo_[a]) / width_[a]);
      c[a] = static_cast<int>(std::clamp(t, 0.0, static_cast<double>(count_[a] - 1)));
    }
    return c;
  }
  std::size_t flat(const std::array<int, 3>& c) const {
    return (static_cast<std::size_t>(c[2]) * static_cast<std::size_t>(count_[1]) +
            static_cast<std::size_t>(c[1])) *
               static_cast<std::size_t>(count_[0]) +
           static_cast<std::size_t>(c[0]);
  }

  std::array<double, 3> lo_{}, hi_{}, length_{}, width_{};
  std::array<int, 3> count_{};
  std::array<bool, 3> periodic_{}, wraps_{};
  std::vector<Eigen::Vector3d> centre_;
  std::vector<double> radius_;
  std::vector<std::uint32_t> selected_;
  std::vector<std::size_t> begin_, members_;
};

/// The particles @p stream owes by @p time, having inserted @p progress so far: whether particle
/// n (of mass @p mass) is due, by count or when its mass fits under the mass due, so that neither
/// ever runs ahead of the rate.
class DueParticles {
 public:
  DueParticles(const StreamInsertion& spec, double time, const ParticleTally& progress)
      : spec_(spec), progress_(progress) {
    elapsed_ = std::min(time, spec.end_time) - spec.start_time;
    // The relative slack absorbs the rounding of the decimal times: 33 000/s from 0.0505 to
    // 0.0565 s owes 198 particles, not floor(197.99999999999994). It is 0.01 particle at the
    // most particles a stream may add (1e8), far below one.
    constexpr double kCountSlack = 1e-10;
    due_count_ = std::floor(spec.particle_rate * elapsed_ * (1.0 + kCountSlack));
    due_mass_ = spec.mass_rate * elapsed_;
  }
  /// Whether the stream has started, and a count stream owes its next particle (known without
  /// drawing its radius).
  bool may_owe() const {
    if (!(elapsed_ > 0.0)) return false;
    return !(spec_.particle_rate > 0.0) || static_cast<double>(progress_.count) < due_count_;
  }
  /// Whether the next particle, of mass @p mass, is due.
  bool operator()(double mass) const {
    return spec_.particle_rate > 0.0 ? static_cast<double>(progress_.count) < due_count_
                                     : progress_.mass + mass <= due_mass_;
  }

 private:
  const StreamInsertion& spec_;
  const ParticleTally& progress_;
  double elapsed_ = 0.0, due_count_ = 0.0, due_mass_ = 0.0;
};

}  // namespace

double stream_radius(const ParticleStream& stream, std::size_t stream_index, std::int64_t n) {
  Rng rng = keyed_rng(stream, stream_index, kRadiusDraws, n, 0);
  return draw_radius(stream.spec.radius, rng);
}

bool stream_due(const ParticleStream& stream, std::size_t stream_index, double time,
                const ParticleTally& progress) {
  const DueParticles due(stream.spec, time, progress);
  // Most steps owe nothing: a count stream knows so without drawing the next radius.
  if (!due.may_owe()) return false;
  return due(sphere_mass(stream_radius(stream, stream_index, progress.count), stream.density));
}

std::vector<std::uint32_t> particles_near_stream(const ParticleStream& stream,
                                                 double largest_radius, const Domain& domain,
                                                 const Particles& particles) {
  return RegionGrid(stream.spec.region, largest_radius, domain, particles).selected();
}

std::size_t insert_due_particles(const ParticleStream& stream, std::size_t stream_index,
                                 double time, std::int64_t step, const Domain& domain,
                                 double largest_radius, Particles& particles, std::int64_t& next_id,
                                 ParticleTally& progress, const std::vector<Boundary>& boundaries) {
  if (!stream_due(stream, stream_index, time, progress)) return 0;  // most steps
  const StreamInsertion& spec = stream.spec;
  const DueParticles due(spec, time, progress);
  const double first_radius = stream_radius(stream, stream_index, progress.count);
  const auto mass_of = [&](double r) { return sphere_mass(r, stream.density); };

  const RegionGrid grid(spec.region, largest_radius, domain, particles);
  std::vector<Eigen::Vector3d> placed;  // this call's particles, in local coordinates
  std::vector<double> placed_radius;
  std::size_t added = 0;
  for (double r = first_radius; due(mass_of(r));
       r = stream_radius(stream, stream_index, progress.count)) {
    Rng rng = keyed_rng(stream, stream_index, kCentreDraws, progress.count, step);
    std::optional<Eigen::Vector3d> free;
    for (std::size_t attempt = 0; attempt < spec.max_attempts && !free; ++attempt) {
      Eigen::Vector3d centre;
      for (int a = 0; a < 3; ++a) {
        // A face (no extent) holds its centres; a box keeps every sphere inside.
        const double lo = spec.region.min[a] + (spec.region.max[a] > spec.region.min[a] ? r : 0.0);
        const double hi = spec.region.max[a] - (spec.region.max[a] > spec.region.min[a] ? r : 0.0);
        centre[a] = std::clamp(lo + uniform01(rng) * (hi - lo), lo, hi);
      }
      const Eigen::Vector3d u = grid.local(centre);
      bool blocked = grid.overlaps(u, r);
      for (std::size_t b = 0; b < boundaries.size() && !blocked; ++b) {
        blocked = overlaps(boundaries[b], centre, r);
      }
      for (std::size_t k = 0; k < placed.size() && !blocked; ++k) {
        blocked = !grid.apart(u, r, placed[k], placed_radius[k]);
      }
      if (!blocked) free = centre;
    }
    if (!free) break;  // no room now: this particle and the later ones wait
    const double mass = mass_of(r);
    const std::size_t i =
        particles.add(next_id++, spec.material, r, mass, free->data(), spec.velocity.data());
    if (particles.thermal()) {
      particles.temperature[i] = spec.temperature;
      particles.peak_temperature[i] = spec.temperature;
      particles.inv_heat_capacity[i] = 1.0 / sphere_heat_capacity(mass, stream.specific_heat);
    }
    placed.push_back(grid.local(*free));
    placed_radius.push_back(r);
    ++progress.count;
    progress.mass += mass;
    ++added;
  }
  return added;
}

}  // namespace bondem
