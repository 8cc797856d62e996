#pragma once
/// @file particles.hpp
/// Particle storage as a structure of arrays: one contiguous array per field, and the one table
/// of those fields (kParticleFields) that reordering, checkpoints, the last-good state and the
/// VTK writer read. Kernels index the plain arrays; only bookkeeping goes through the table.

#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "solver/engine/staggered_vector.hpp"

namespace bondem {

/// Below this many particles loops run on one thread: forking a team costs more than the work,
/// and idle threads spinning at barriers starve other processes. Results do not depend on it.
/// Measured on 2 cores: 2 threads already run the 1 100- and 2 000-particle packing cases 1.3 and
/// 1.4 times faster than one.
inline constexpr std::size_t kMinParallelParticles = 1024;

/// Threads the loops over @p particles particles actually use.
inline int threads_in_use(std::size_t particles) {
  return particles >= kMinParallelParticles ? omp_get_max_threads() : 1;
}

/// Per-particle state. Index i addresses the same particle in every array; `id` is the stable
/// identity that survives reordering. Every array is listed once in kParticleFields below.
struct Particles {
  StaggeredVector<std::int64_t> id;
  StaggeredVector<std::int32_t> material;
  StaggeredVector<double> x, y, z;
  StaggeredVector<double> vx, vy, vz;
  StaggeredVector<double> fx, fy, fz;
  StaggeredVector<double> radius, mass;
  StaggeredVector<double> wx, wy, wz;  ///< angular velocity [rad/s]
  StaggeredVector<double> tx, ty, tz;  ///< torque [N m]
  /// Displacement since the particle entered the run [m], summed from the drift's own position
  /// increments: x - x0 up to rounding, and not wrapped across periodic boundaries. Tracked only
  /// when displacement_tracked (the run writes VTK frames, its one reader): 24 B a particle.
  StaggeredVector<double> dx, dy, dz;
  bool displacement_tracked = false;
  /// Tangential spring elongation against each wall, 3 values per wall, wall_count() per particle.
  StaggeredVector<double> wall_slip;
  int walls = 0;  ///< walls with a slot in wall_slip
  /// Per wall and particle, when contact_history: the EPSD rolling spring torque (3 values) and
  /// 1 while a JKR contact holds (a cohesive contact outlives zero overlap), 4 values per wall.
  StaggeredVector<double> wall_contact;
  /// Whether some material pair keeps history beyond the tangential spring (EPSD rolling or JKR
  /// cohesion): then the kContactHistory fields are in use.
  bool contact_history = false;
  /// Per wall slot and particle, when mesh_contacts: the unit normal of the contact the slot held
  /// in the last evaluation (zero: none), 3 values. A mesh contact moving from one triangle to
  /// the next keeps its slot, and so its history, by this normal.
  StaggeredVector<double> wall_normal;
  /// Whether some boundary is a triangle mesh: then the kMeshHistory fields are in use.
  bool mesh_contacts = false;
  // Thermal state; these arrays are empty when the case has no `thermal:` block.
  StaggeredVector<double> temperature;        ///< [K]
  StaggeredVector<double> peak_temperature;   ///< highest temperature reached so far [K]
  StaggeredVector<double> inv_heat_capacity;  ///< 1 / (m c_p) [K/J]
  StaggeredVector<double> heat_rate;          ///< net heat flow in, from the last evaluation [W]

  /// Whether temperatures are tracked (set by track_temperatures(); kept with no particles yet).
  bool thermal() const { return temperatures_tracked; }
  bool temperatures_tracked = false;  ///< see thermal()

  /// Start tracking displacements (the kDisplacementField fields), from zero.
  void track_displacement();

  /// Give every particle zeroed history slots (tangential, and the contact_history ones when in
  /// use) for each of @p wall_count walls.
  void set_wall_count(int wall_count) {
    walls = wall_count;
    wall_slip.assign(size() * static_cast<std::size_t>(3 * wall_count), 0.0);
    wall_contact.assign(
        contact_history ? size() * static_cast<std::size_t>(kWallContactValues * wall_count) : 0,
        0.0);
    wall_normal.assign(mesh_contacts ? size() * static_cast<std::size_t>(3 * wall_count) : 0, 0.0);
  }
  /// Values per wall of wall_contact: rolling spring x, y, z and the JKR flag.
  static constexpr int kWallContactValues = 4;

  /// Number of particles.
  std::size_t size() const { return id.size(); }
  /// The particle indices sorted by id: the order of every output that must not depend on how
  /// the particles are stored (final state, checkpoint, VTK frames). Indices fit 32 bits (the
  /// neighbor list stores them so).
  std::vector<std::uint32_t> order_by_id() const {
    const std::size_t n = size();
    std::vector<std::uint32_t> order(n);
    if (n > 0) {
      // The ids of most runs are a block of consecutive numbers: each index goes straight to its
      // place, one pass instead of a sort that looks every id up (about 80 ms at 10^6).
      const auto [low, high] = std::minmax_element(id.begin(), id.end());
      const auto low_id = static_cast<std::uint64_t>(*low);
      if (static_cast<std::uint64_t>(*high) - low_id == n - 1) {
        constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
        std::fill(order.begin(), order.end(), kEmpty);
        bool distinct = true;
        for (std::size_t i = 0; i < n && distinct; ++i) {
          std::uint32_t& place =
              order[static_cast<std::size_t>(static_cast<std::uint64_t>(id[i]) - low_id)];
          distinct = place == kEmpty;
          place = static_cast<std::uint32_t>(i);
        }
        if (distinct) return order;
      }
    }
    for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
    if (!std::is_sorted(id.begin(), id.end())) {
      std::sort(order.begin(), order.end(),
                [&](std::uint32_t a, std::uint32_t b) { return id[a] < id[b]; });
    }
    return order;
  }
  /// 1 / I of particle i, a solid sphere: I = 2/5 m r^2.
  double inverse_inertia(std::size_t i) const {
    return 1.0 / (0.4 * mass[i] * radius[i] * radius[i]);
  }

  /// Append one particle at rest force-wise; returns its index. Every other field of the table
  /// (thermal ones only when temperatures are tracked) gets zeros.
  std::size_t add(std::int64_t particle_id, std::int32_t material_index, double particle_radius,
                  double particle_mass, const double position[3], const double velocity[3]);

  /// @p count particles of zeros in every field in use, as @p count add()s of zeros would leave
  /// them, the pages cleared on every thread (assign_zeros); for a set that then fills them.
  void assign_zeros(std::size_t count);

  /// Reorder every field marked kReordered so that new index k holds old particle order[k]; an
  /// order shorter than size() drops the particles it leaves out.
  void permute(std::span<const std::uint32_t> order);

  /// The particles at @p order (indices into these) in that order, as permute() would leave a
  /// copy, without copying the others first.
  Particles selected(const std::vector<std::uint32_t>& order) const;

 private:
  /// Every field of @p from gathered at @p order into @p to (which may be @p from).
  static void gather(const Particles& from, std::span<const std::uint32_t> order, Particles& to);

 public:
  /// Start tracking temperatures: every kThermal field gets a zero per particle, for the scene
  /// to fill in (a thermal field added to the table then needs no line of its own there).
  void track_temperatures();
};

/// What a particle field takes part in: bits of ParticleField::flags.
enum ParticleFieldFlag : unsigned {
  kReordered = 1U << 0U,     ///< moved with the particles by Particles::permute
  kCheckpointed = 1U << 1U,  ///< written to and read from checkpoints (exact restarts)
  kLastGood = 1U << 2U,      ///< kept by LastGoodFile (the fields of a final-state file)
  kThermal = 1U << 3U,       ///< present (non-empty) only when temperatures are tracked
  kPerWall = 1U << 4U,       ///< wall_values per wall slot and particle (Particles::walls), not 1
  /// Present (non-empty) only when Particles::contact_history (EPSD rolling or JKR cohesion).
  kContactHistory = 1U << 5U,
  /// Present (non-empty) only when Particles::displacement_tracked.
  kDisplacementField = 1U << 6U,
  /// Present (non-empty) only when Particles::mesh_contacts (some boundary is a mesh).
  kMeshHistory = 1U << 7U,
};

/// Pointer to one array of Particles, of any of the element types the table holds.
using ParticleMember =
    std::variant<StaggeredVector<std::int64_t> Particles::*,
                 StaggeredVector<std::int32_t> Particles::*, StaggeredVector<double> Particles::*>;

/// VTK place of the arrays a caller derives per frame (VtkSeriesWriter::write_frame's scalars
/// and vectors): the particle file lists its arrays by ascending ParticleField::vtk_order.
inline constexpr int kVtkDerivedScalarsOrder = 10;
/// See kVtkDerivedScalarsOrder.
inline constexpr int kVtkDerivedVectorsOrder = 20;

/// One row of the particle-field table.
struct ParticleField {
  std::string_view name;  ///< the member's name
  ParticleMember member;  ///< the array itself
  unsigned flags = 0;     ///< ParticleFieldFlag bits
  /// Name of the VTK point array it is written to; empty: not written (positions are the
  /// points themselves). Three rows with one name and components 0, 1, 2 form one 3-vector.
  std::string_view vtk_name = {};
  int vtk_component = -1;  ///< -1: a scalar array; 0, 1, 2: x, y, z of a vector array
  /// Place among the particle file's point arrays (ascending); the derived arrays of the caller
  /// sit at kVtkDerivedScalarsOrder and kVtkDerivedVectorsOrder.
  int vtk_order = 0;
  int wall_values = 3;  ///< values per wall slot of a kPerWall field
};

/// Every particle array, once. Table order is checkpoint order within each of its sections
/// (per-particle, per-wall, thermal: see io/checkpoint.cpp); keep new rows at the end of theirs.
inline constexpr ParticleField kParticleFields[] = {
    {"id", &Particles::id, kReordered | kCheckpointed | kLastGood, "id", -1, 1},
    {"material", &Particles::material, kReordered | kCheckpointed | kLastGood, "material", -1, 5},
    {"x", &Particles::x, kReordered | kCheckpointed | kLastGood},
    {"y", &Particles::y, kReordered | kCheckpointed | kLastGood},
    {"z", &Particles::z, kReordered | kCheckpointed | kLastGood},
    {"vx", &Particles::vx, kReordered | kCheckpointed | kLastGood, "velocity", 0, 3},
    {"vy", &Particles::vy, kReordered | kCheckpointed | kLastGood, "velocity", 1, 3},
    {"vz", &Particles::vz, kReordered | kCheckpointed | kLastGood, "velocity", 2, 3},
    {"fx", &Particles::fx, kReordered | kCheckpointed, "force", 0, 4},
    {"fy", &Particles::fy, kReordered | kCheckpointed, "force", 1, 4},
    {"fz", &Particles::fz, kReordered | kCheckpointed, "force", 2, 4},
    {"radius", &Particles::radius, kReordered | kCheckpointed | kLastGood, "radius", -1, 2},
    {"mass", &Particles::mass, kReordered | kCheckpointed},
    {"wx", &Particles::wx, kReordered | kCheckpointed | kLastGood, "angular_velocity", 0, 21},
    {"wy", &Particles::wy, kReordered | kCheckpointed | kLastGood, "angular_velocity", 1, 21},
    {"wz", &Particles::wz, kReordered | kCheckpointed | kLastGood, "angular_velocity", 2, 21},
    {"tx", &Particles::tx, kReordered | kCheckpointed, "torque", 0, 22},
    {"ty", &Particles::ty, kReordered | kCheckpointed, "torque", 1, 22},
    {"tz", &Particles::tz, kReordered | kCheckpointed, "torque", 2, 22},
    {"dx", &Particles::dx, kReordered | kCheckpointed | kDisplacementField, "displacement", 0, 23},
    {"dy", &Particles::dy, kReordered | kCheckpointed | kDisplacementField, "displacement", 1, 23},
    {"dz", &Particles::dz, kReordered | kCheckpointed | kDisplacementField, "displacement", 2, 23},
    {"wall_slip", &Particles::wall_slip, kReordered | kCheckpointed | kPerWall},
    {"wall_contact",
     &Particles::wall_contact,
     kReordered | kCheckpointed | kPerWall | kContactHistory,
     {},
     -1,
     0,
     Particles::kWallContactValues},
    {"wall_normal", &Particles::wall_normal, kReordered | kCheckpointed | kPerWall | kMeshHistory},
    {"temperature", &Particles::temperature, kReordered | kCheckpointed | kThermal, "temperature",
     -1, 11},
    {"peak_temperature", &Particles::peak_temperature, kReordered | kCheckpointed | kThermal,
     "peak_temperature", -1, 12},
    {"inv_heat_capacity", &Particles::inv_heat_capacity, kReordered | kCheckpointed | kThermal},
    {"heat_rate", &Particles::heat_rate, kReordered | kCheckpointed | kThermal, "heat_rate", -1,
     13},
};

/// Whether @p field has every bit of @p flags.
constexpr bool has(const ParticleField& field, unsigned flags) {
  return (field.flags & flags) == flags;
}

/// Values @p field holds per particle of @p p: wall_values per wall slot for kPerWall fields,
/// else 1.
inline std::size_t values_per_particle(const ParticleField& field, const Particles& p) {
  return has(field, kPerWall) ? static_cast<std::size_t>(field.wall_values * p.walls) : 1;
}

/// Whether @p field is in use in @p p: thermal fields only when temperatures are tracked, contact
/// history fields only when some pair keeps it.
inline bool in_use(const ParticleField& field, const Particles& p) {
  return (!has(field, kThermal) || p.thermal()) &&
         (!has(field, kContactHistory) || p.contact_history) &&
         (!has(field, kDisplacementField) || p.displacement_tracked) &&
         (!has(field, kMeshHistory) || p.mesh_contacts);
}

/// Consistency of the table, checked at compile time: unique names; a vector's three components
/// share its VTK order and are doubles; VTK arrays and their orders are unique and stay clear of
/// the derived arrays' places; per-wall fields are doubles and not written to VTK.
constexpr bool particle_fields_consistent() {
  constexpr std::size_t kDouble = 2;  // variant index of StaggeredVector<double> Particles::*
  for (const ParticleField& a : kParticleFields) {
    if (a.name.empty()) return false;
    if (has(a, kPerWall) && (a.member.index() != kDouble || !a.vtk_name.empty())) return false;
    if (a.vtk_name.empty()) continue;
    if (a.vtk_order == kVtkDerivedScalarsOrder || a.vtk_order == kVtkDerivedVectorsOrder) {
      return false;
    }
    if (a.vtk_component >= 0 && a.member.index() != kDouble) return false;
    int components = 0;
    for (const ParticleField& b : kParticleFields) {
      if (&a != &b && a.name == b.name) return false;
      if (b.vtk_name.empty()) continue;
      if ((a.vtk_name == b.vtk_name) != (a.vtk_order == b.vtk_order)) return false;
      if (a.vtk_name != b.vtk_name) continue;
      if (a.vtk_component < 0 && &a != &b) return false;  // a scalar has one row
      if (b.vtk_component < 0 || b.vtk_component > 2) continue;
      components |= 1 << b.vtk_component;
      if (&a != &b && a.vtk_component == b.vtk_component) return false;
    }
    if (a.vtk_component >= 0 && components != 7) return false;
  }
  return true;
}
static_assert(particle_fields_consistent(), "kParticleFields: see particle_fields_consistent()");

inline std::size_t Particles::add(std::int64_t particle_id, std::int32_t material_index,
                                  double particle_radius, double particle_mass,
                                  const double position[3], const double velocity[3]) {
  const std::size_t index = size();
  for (const ParticleField& field : kParticleFields) {
    if (!in_use(field, *this)) continue;
    const std::size_t count = values_per_particle(field, *this);
    std::visit([&](auto member) { (this->*member).resize((this->*member).size() + count); },
               field.member);
  }
  id[index] = particle_id;
  material[index] = material_index;
  x[index] = position[0];
  y[index] = position[1];
  z[index] = position[2];
  vx[index] = velocity[0];
  vy[index] = velocity[1];
  vz[index] = velocity[2];
  radius[index] = particle_radius;
  mass[index] = particle_mass;
  return index;
}

inline void Particles::assign_zeros(std::size_t count) {
  for (const ParticleField& field : kParticleFields) {
    if (!in_use(field, *this)) continue;
    const std::size_t values = count * values_per_particle(field, *this);
    std::visit([&](auto member) { bondem::assign_zeros(this->*member, values); }, field.member);
  }
}

inline void Particles::permute(std::span<const std::uint32_t> order) {
  gather(*this, order, *this);
}

inline Particles Particles::selected(const std::vector<std::uint32_t>& order) const {
  Particles chosen;
  // Every member that is not a field of kParticleFields.
  chosen.displacement_tracked = displacement_tracked;
  chosen.walls = walls;
  chosen.contact_history = contact_history;
  chosen.mesh_contacts = mesh_contacts;
  chosen.temperatures_tracked = temperatures_tracked;
  gather(*this, order, chosen);
  return chosen;
}

inline void Particles::gather(const Particles& from, std::span<const std::uint32_t> order,
                              Particles& to) {
  // In place, the old buffer of each double array takes the next one's values: a fresh buffer per
  // array faulted in about 150 MB of new pages on one thread at 10^6 particles (a page touched
  // for the first time costs ~10 us here, see staggered_vector.hpp).
  const bool in_place = &from == &to;
  StaggeredVector<double> spare;
  const std::size_t count = order.size();
  for (const ParticleField& field : kParticleFields) {
    if (!has(field, kReordered)) continue;
    const std::size_t stride = values_per_particle(field, from);
    std::visit(
        [&](auto member) {
          const auto& values = from.*member;
          if (values.empty()) return;  // thermal fields of a run without temperatures
          using Vector = std::remove_cvref_t<decltype(values)>;
          Vector local;
          Vector* reordered = &local;
          if constexpr (std::is_same_v<Vector, StaggeredVector<double>>) {
            if (in_place) reordered = &spare;
          }
          const std::size_t values_needed = count * stride;
          // A spare much larger than needed (a per-wall array's, for one value a particle) would
          // stay with this array as unused capacity: then a buffer of its own.
          const std::size_t room = reordered->capacity();
          if (room >= values_needed && room - values_needed <= values_needed / 8) {
            reordered->resize(values_needed);
          } else {
            Vector().swap(*reordered);                        // never kept as spare capacity
            bondem::assign_zeros(*reordered, values_needed);  // pages mapped on every thread
          }
          auto* const out = reordered->data();
          const auto* const in = values.data();
          const auto particles = static_cast<std::int64_t>(count);
#pragma omp parallel for schedule(static) if (count >= kMinParallelParticles)
          for (std::int64_t k = 0; k < particles; ++k) {
            const auto at = static_cast<std::size_t>(k);
            if (stride == 1) {
              out[at] = in[order[at]];
            } else {
              std::copy_n(in + order[at] * stride, stride, out + at * stride);
            }
          }
          (to.*member).swap(*reordered);  // after reading: `to` may be `from`
        },
        field.member);
  }
}

inline void Particles::track_displacement() {
  displacement_tracked = true;
  for (const ParticleField& field : kParticleFields) {
    if (has(field, kDisplacementField)) {
      std::visit([&](auto member) { (this->*member).assign(size(), {}); }, field.member);
    }
  }
}

inline void Particles::track_temperatures() {
  temperatures_tracked = true;
  for (const ParticleField& field : kParticleFields) {
    if (has(field, kThermal)) {
      std::visit([&](auto member) { (this->*member).assign(size(), {}); }, field.member);
    }
  }
}

}  // namespace bondem
