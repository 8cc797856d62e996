#pragma once
/// @file particle_stream.hpp
/// Insertion during a run: a stream adds particles at a rate into a region, each where it
/// overlaps no particle, as space allows. Serial and keyed by (seed, stream, particle, step), so
/// the particles inserted are the same bytes for any thread count and across restarts: a
/// checkpoint carries only each stream's ParticleTally.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "geometry/boundary.hpp"
#include "geometry/domain.hpp"
#include "solver/engine/particles.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// A count of particles and their mass: what a stream has inserted so far, or what left the
/// domain.
struct ParticleTally {
  std::int64_t count = 0;  ///< particles
  double mass = 0.0;       ///< their mass [kg]
};

/// A case's stream with what the scene knows of its material.
struct ParticleStream {
  StreamInsertion spec;
  double density = 0.0;        ///< of the material [kg/m^3]
  double specific_heat = 0.0;  ///< of the material [J/(kg K)], used in thermal runs
};

/// Radius of particle @p n of stream @p stream_index: drawn from its own generator, so a particle
/// that waits for room keeps its size.
double stream_radius(const ParticleStream& stream, std::size_t stream_index, std::int64_t n);

/// Whether @p stream owes a particle by @p time, having inserted @p progress so far: whether
/// insert_due_particles() would look for room at all (most steps it would not).
bool stream_due(const ParticleStream& stream, std::size_t stream_index, double time,
                const ParticleTally& progress);

/// The particles of @p particles that insert_due_particles() tests new ones of @p stream against
/// (those within reach of its region, periodic images resolved), by index.
std::vector<std::uint32_t> particles_near_stream(const ParticleStream& stream,
                                                 double largest_radius, const Domain& domain,
                                                 const Particles& particles);

/// Insert into @p particles the particles of @p stream due by @p time (its rate times the time
/// since its start, capped at its end), each at a random centre of its region that overlaps no
/// particle (touching allowed; periodic axes of @p domain wrap) and none of @p boundaries at their
/// current pose (a blade passing through the region), trying spec.max_attempts centres per
/// particle. A particle that finds no room waits for the next call, and so do those after it.
/// @p largest_radius bounds every radius in the run (the reach of the overlap test); @p step keys
/// the random centres. New particles get ids @p next_id, @p next_id + 1, ... Returns the count.
std::size_t insert_due_particles(const ParticleStream& stream, std::size_t stream_index,
                                 double time, std::int64_t step, const Domain& domain,
                                 double largest_radius, Particles& particles, std::int64_t& next_id,
                                 ParticleTally& progress,
                                 const std::vector<Boundary>& boundaries = {});

}  // namespace bondem
