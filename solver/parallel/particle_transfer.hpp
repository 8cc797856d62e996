#pragma once
/// @file particle_transfer.hpp
/// Moving whole particles between particle sets: a ghost takes its owner's state, a migrating
/// particle joins another rank's set, and either travels between processes as bytes.

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <variant>
#include <vector>

#include "solver/engine/particles.hpp"

namespace bondem {

/// Calls @p visit(member, stride) for every field @p p uses (every kReordered field of
/// kParticleFields whose array is not empty), in table order; member is a pointer to the
/// Particles array, stride its values per particle.
template <class Visit>
void for_each_used_field(const Particles& p, Visit&& visit) {
  for (const ParticleField& field : kParticleFields) {
    if (!has(field, kReordered)) continue;
    const std::size_t stride = values_per_particle(field, p);
    std::visit(
        [&](auto member) {
          if (!(p.*member).empty()) visit(member, stride);
        },
        field.member);
  }
}

/// Overwrites particle @p k of @p to with particle @p i of @p from (every field @p from uses).
inline void copy_particle(const Particles& from, std::size_t i, Particles& to, std::size_t k) {
  for_each_used_field(from, [&](auto member, std::size_t stride) {
    std::copy_n((from.*member).begin() + static_cast<std::ptrdiff_t>(i * stride), stride,
                (to.*member).begin() + static_cast<std::ptrdiff_t>(k * stride));
  });
}

/// Appends particle @p i of @p from to @p to, which uses the same fields.
inline void append_particle(const Particles& from, std::size_t i, Particles& to) {
  for_each_used_field(from, [&](auto member, std::size_t stride) {
    const auto first = (from.*member).begin() + static_cast<std::ptrdiff_t>(i * stride);
    (to.*member).insert((to.*member).end(), first, first + static_cast<std::ptrdiff_t>(stride));
  });
}

/// One particle of zeros with every field @p like uses: the layout of every record of its run,
/// also when @p like holds no particle yet (a run that a stream fills).
inline Particles particle_prototype(const Particles& like) {
  Particles one = like.selected({});
  const double zero[3] = {0.0, 0.0, 0.0};
  one.add(0, 0, 0.0, 0.0, zero, zero);
  return one;
}

/// Appends the bytes of particle @p i of @p p (every field it uses, in table order) to @p out:
/// the same size for every particle of a run.
inline void pack_particle(const Particles& p, std::size_t i, std::vector<char>& out) {
  for_each_used_field(p, [&](auto member, std::size_t stride) {
    const auto& values = p.*member;
    const char* first = reinterpret_cast<const char*>(values.data() + i * stride);
    out.insert(out.end(), first, first + stride * sizeof(values[0]));
  });
}

/// Reads one particle that pack_particle wrote at @p in into particle @p k of @p p, which uses
/// the same fields; returns the bytes read.
inline std::size_t unpack_particle(const char* in, Particles& p, std::size_t k) {
  std::size_t read = 0;
  for_each_used_field(p, [&](auto member, std::size_t stride) {
    auto& values = p.*member;
    const std::size_t bytes = stride * sizeof(values[0]);
    std::memcpy(reinterpret_cast<char*>(values.data() + k * stride), in + read, bytes);
    read += bytes;
  });
  return read;
}

}  // namespace bondem
