#pragma once
/// @file particle_list.hpp
/// A case's initial particles: explicit and inserted ones in order, a lattice kept as its
/// description (a few numbers) rather than one record per sphere.
///
/// A decomposed run starts with every process reading the same case: were a 10^8 lattice expanded
/// on each of them, 10 GB a process would go to particles that all but one process drop. Kept as
/// a LatticeBlock, particle k is computed when it is read, and a process walks the list keeping
/// only its own.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <iterator>
#include <vector>

namespace bondem {

/// One explicitly listed particle.
struct ParticleSpec {
  int material = 0;  ///< index into Case::materials
  double radius = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  double temperature = 293.15;  ///< [K]; the reader fills in the thermal initial temperature
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< [rad/s]
  /// Stable id; -1: the next free one (build_scene). Particles of an initial state keep theirs.
  std::int64_t id = -1;
};

/// A simple-cubic lattice of equal spheres: centres at origin + spacing (i, j, k), x varying
/// fastest, then y, then z; every sphere with the same material, velocity and temperature.
struct LatticeBlock {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< the first centre
  double spacing = 0.0;
  double radius = 0.0;
  int material = 0;
  std::array<std::size_t, 3> counts{};  ///< spheres along x, y and z
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  double temperature = 293.15;  ///< [K]

  /// Number of spheres.
  std::size_t size() const { return counts[0] * counts[1] * counts[2]; }
  /// Sphere @p k (< size()) in lattice order.
  ParticleSpec at(std::size_t k) const {
    const std::size_t i = k % counts[0];
    const std::size_t j = k / counts[0] % counts[1];
    const std::size_t l = k / counts[0] / counts[1];
    ParticleSpec p;
    p.material = material;
    p.radius = radius;
    p.position = origin + spacing * Eigen::Vector3d(static_cast<double>(i), static_cast<double>(j),
                                                    static_cast<double>(l));
    p.velocity = velocity;
    p.temperature = temperature;
    return p;
  }
  /// The centre furthest from the origin (the lattice's bounding box is origin..last_centre).
  Eigen::Vector3d last_centre() const {
    return origin + spacing * Eigen::Vector3d(static_cast<double>(counts[0] - 1),
                                              static_cast<double>(counts[1] - 1),
                                              static_cast<double>(counts[2] - 1));
  }
};

/// The initial particles of a case in their order (their ids follow it): runs of stored specs
/// and lattice blocks. Reading gives values; ParticleList::edit() and expanded() give references
/// and expand every block first.
class ParticleList {
 public:
  /// Reads the list in order, one value at a time.
  class Iterator {
   public:
    using iterator_category = std::input_iterator_tag;
    using value_type = ParticleSpec;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = const ParticleSpec;

    Iterator(const ParticleList* list, std::size_t index) : list_(list), index_(index) {}
    const ParticleSpec operator*() const { return (*list_)[index_]; }
    Iterator& operator++() {
      ++index_;
      return *this;
    }
    Iterator operator++(int) {
      Iterator before = *this;
      ++index_;
      return before;
    }
    bool operator==(const Iterator& other) const { return index_ == other.index_; }
    bool operator!=(const Iterator& other) const { return index_ != other.index_; }

   private:
    const ParticleList* list_;
    std::size_t index_;
  };

  ParticleList() = default;
  /// A list of these stored specs.
  ParticleList(std::vector<ParticleSpec> specs);  // NOLINT(google-explicit-constructor)
  /// A list of these stored specs.
  ParticleList(std::initializer_list<ParticleSpec> specs);

  /// Number of particles, stored and in lattice blocks.
  std::size_t size() const { return in_blocks_ + stored_.size(); }
  /// Whether the list holds no particle.
  bool empty() const { return size() == 0; }
  /// Particle @p i (< size()), by value: const, so that assigning to a member of it cannot
  /// compile (edit() changes a particle).
  const ParticleSpec operator[](std::size_t i) const;
  /// The first particle (the list must not be empty).
  const ParticleSpec front() const { return (*this)[0]; }
  /// Reading in order.
  Iterator begin() const { return {this, 0}; }
  /// Past the last particle.
  Iterator end() const { return {this, size()}; }

  /// Appends one stored spec.
  void push_back(const ParticleSpec& spec);
  /// Appends stored specs in their order.
  void append(std::vector<ParticleSpec> specs);
  /// Appends a lattice block, which stores no spec.
  void append(const LatticeBlock& block);

  /// Particle @p i for changing it: expands every lattice block into stored specs first.
  ParticleSpec& edit(std::size_t i);
  /// Every particle stored, for changing them (resizing included, until the list is next
  /// appended to): expands every lattice block first.
  std::vector<ParticleSpec>& expanded();
  /// Specs held one by one (a lattice block holds none).
  std::size_t stored_count() const { return stored_.size(); }
  /// The lattice blocks, in list order.
  std::vector<LatticeBlock> lattice_blocks() const;
  /// Empties the list and releases its memory.
  void clear();

 private:
  /// A run of the list from index `first`: stored specs from stored_[stored_first], or a block.
  struct Segment {
    std::size_t first = 0;
    std::size_t stored_first = 0;
    bool is_lattice = false;
    LatticeBlock lattice;
  };
  const Segment& segment_of(std::size_t i) const;

  std::vector<ParticleSpec> stored_;
  std::vector<Segment> segments_;
  std::size_t in_blocks_ = 0;  ///< particles in lattice blocks
};

}  // namespace bondem
