#pragma once
/// @file pair_kernel_simd.hpp
/// Pass 1 of the force kernels (compute_pair_forces in contact_kernel.hpp) in SIMD lanes, one
/// candidate pair per lane, for the runs whose every pair has a vector form (simd_pass_applies):
/// the Hertz + bond law with alpha_adh = 1 (both adhesion inputs, every bonding criterion),
/// Mindlin-Coulomb friction and constant-torque rolling resistance. Other runs (the Hooke law,
/// alpha_adh != 1, which needs std::pow, sJKR and JKR cohesion, EPSD rolling resistance, heat
/// conduction) take the scalar pass.
///
/// Compiled for several instruction sets through Google Highway and chosen at run time
/// (select_simd_target). Every target gives the same bytes: the lanes perform the same IEEE
/// operations in the same order on every target, scalar included (contact_lanes-inl.h).

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "solver/engine/contact_kernel.hpp"

namespace bondem {

/// An instruction set of the SIMD pass; kAuto is the best this CPU supports.
enum class SimdTarget { kAuto, kScalar, kSse4, kAvx2, kAvx512 };

/// The target named @p name (auto, scalar, sse4, avx2, avx512), or none.
std::optional<SimdTarget> parse_simd_target(std::string_view name);

/// The name parse_simd_target reads.
const char* simd_target_name(SimdTarget target);

/// The targets compiled in and supported by this CPU, best last (kAuto not included).
std::vector<SimdTarget> supported_simd_targets();

/// Runs the SIMD pass on @p target from now on (process-wide; kAuto: the best supported).
/// Throws std::invalid_argument naming the supported targets when this CPU lacks @p target.
void select_simd_target(SimdTarget target);

/// The target the SIMD pass runs on now (never kAuto).
SimdTarget simd_target_in_use();

/// Why a run with normal law @p law, material-pair table @p pairs and heat conduction
/// (@p thermal) takes the scalar pass (e.g. "JKR cohesion"), or nullptr when its
/// pairs take the SIMD pass.
const char* scalar_pass_reason(const NormalLawSpec& law, const std::vector<PairCoefficients>& pairs,
                               bool thermal);

/// Whether the forces of @p scene's pairs take the SIMD pass (scalar_pass_reason gives none).
bool simd_pass_applies(const Scene& scene);

/// A material pair's constants in the form the lanes use (contact_lanes-inl.h).
struct LanePairConstants {
  double four_thirds_e = 0.0;        ///< (4/3) E*
  double two_e = 0.0;                ///< 2 E*
  double two_xi_contact = 0.0;       ///< 2 xi_con
  double two_xi_bond = 0.0;          ///< 2 xi_bond
  double equilibrium_overlap = 0.0;  ///< delta_eq when given (else computed per pair)
  double adhesion_stiffness = 0.0;   ///< k_adh when given (else computed per pair)
  double stiffness_input = 0.0;      ///< 1 where k_adh is the input, 0 where delta_eq is
  double critical_ratio = 0.0;       ///< delta_crit / delta_eq
  double eight_g = 0.0;              ///< 8 G*, Mindlin's k_t = 8 G* a
  double tangential_ratio = 0.0;     ///< sqrt(4 G* / E*) = sqrt(k_t / k_con)
  double friction = 0.0;             ///< mu
  double rolling_friction = 0.0;     ///< mu_r (constant-torque rolling resistance)
};

/// The lane constants of every material pair of @p scene, in pair_table order.
std::vector<LanePairConstants> lane_pair_constants(const Scene& scene);

/// What the SIMD pass keeps from call to call: below set_kinematics_records_below's limit (by
/// default 2^19 particles, pair_kernel_simd.cpp), each particle's position, radius, velocity and
/// mass as two quadruples and, where records_hold_spins, its spin as a third, which the block
/// gather transposes into lanes with a load per quadruple where it reads eleven arrays, written by
/// the opening sweep (records_for_sweep) or copied by the pass.
struct LanePassScratch {
  StaggeredVector<double> kinematics;  ///< 8 values a particle, 12 where records_hold_spins
  /// Whether @c kinematics holds the particles' kinematics as they are now: set by whoever wrote
  /// them outside the pass (the opening sweep), cleared by the pass that reads them and by
  /// anything that moves, reorders, adds or removes particles in between.
  bool current = false;
};

/// Runs from @p particles particles on read the particle arrays instead of kinematics records
/// (LanePassScratch), which cost 64 B a particle, 96 B where they hold the spins (default 2^19);
/// returns the previous limit. Process-wide, for tests and benchmarks: set it between steps. Both
/// ways give the same bytes.
std::size_t set_kinematics_records_below(std::size_t particles);

/// Runs from @p particles particles on write the pass's force slots with non-temporal stores
/// (default 57 344, measured where the step's data outgrows this machine's L3); returns the
/// previous limit. Process-wide, for tests and benchmarks: set it between steps. Both ways give
/// the same bytes.
std::size_t set_stream_pair_slots_from(std::size_t particles);

/// Runs below @p particles particles (default 57 344: where the step's data stays in this
/// machine's L3) keep each pair's force, n x F_t and delta as one 64-B record (PairForces::records)
/// where keeps_pair_records says so; returns the previous limit. Process-wide, for tests and
/// benchmarks: set it between steps. Both ways give the same bytes.
std::size_t set_pair_records_below(std::size_t particles);

/// Whether a run of @p particles particles whose pairs take the SIMD pass keeps them as records:
/// with @p friction, without @p rolling resistance or heat (@p thermal), below the limit.
bool keeps_pair_records(std::size_t particles, bool friction, bool rolling, bool thermal);

/// Whether the SIMD pass over @p particles particles reads kinematics records
/// (set_kinematics_records_below).
bool pass_reads_records(std::size_t particles);
/// Where the opening sweep writes the kinematics records of the next pass: null where none.
struct SweepRecords {
  double* kinematics = nullptr;  ///< SweepArrays::records
  double* spins = nullptr;       ///< SweepArrays::spin_records, where records_hold_spins
};

/// Where the opening sweep of @p particles particles of a run with @p friction can write the
/// kinematics records of the next pass, sized for them, or nulls when the pass reads none at this
/// count (it then reads the particle arrays); with @p fused, for the fused pass, which reads them
/// at every count. The caller sets @c current once they are written.
SweepRecords records_for_sweep(LanePassScratch& scratch, std::size_t particles, bool friction,
                               bool fused = false);

/// The kinematics records of @p p's particles as they are now for the fused pass, which reads them
/// at every count (simd_pair_forces_fused), filled here unless @p scratch's are current; clears
/// current.
SweepRecords current_records(const Particles& p, bool friction, LanePassScratch& scratch);
/// Whether the kinematics records of a run with @p friction hold the spins too, (wx, wy, wz, 0)
/// after the velocities: with friction on AVX-512, where the gather transposes eight of them at a
/// time (the 20 800 peer lattice 0.96 of the time; on AVX2 and SSE4 1.00-1.04, left out).
bool records_hold_spins(bool friction);

/// Pass 1 as compute_pair_forces<kFriction = scene.friction, kModels = false> with the Hertz +
/// bond law, in lanes of the selected target. Requires simd_pass_applies(scene). @p counted as
/// in compute_pair_forces. @p split: the threads' shares of the rows, kept across calls and
/// balanced by their measured times; null: equal shares. @p scratch: kept across calls; null: a
/// buffer of this call's own.
ContactSummary simd_pair_forces(const Particles& p, const Scene& scene, const NeighborList& list,
                                std::span<const LanePairConstants> constants,
                                const BondingCriterion& criterion_met, PairForces& out,
                                PairHistory& history, const std::uint8_t* counted = nullptr,
                                ThreadSplit* split = nullptr, LanePassScratch* scratch = nullptr);

/// Where simd_pair_forces_fused keeps its force slots: a ring of @c pairs pairs.
struct FusedRing {
  /// fx, fy, fz, cx, cy, cz, overlap (the first three without friction), 2 @c pairs each: pair
  /// k's at [k mod pairs] once its run is done.
  double* slots[7] = {};
  /// Or, where set (with friction), records (fx, fy, fz, delta, cx, cy, cz, 0), 2 @c pairs of
  /// them: pair k's at 8 (k mod pairs).
  double* records = nullptr;
  std::uint32_t pairs = 0;  ///< a power of two, at least the pairs of any run
  /// Where the pairs read after the ring has moved past them are copied to.
  KeptPairs kept;
  std::size_t run_rows = 0;  ///< rows per run
};
/// Pass 1 as simd_pair_forces over rows [@p first_row, @p end_row) on the calling thread, run by
/// run (runs end on multiples of @p ring.run_rows), the slots in @p ring, calling
/// @p done(first, end) after each run [first, end). No kinematics or pair records, no rolling
/// slots, every pair counted; @p out's force slots, if it has any, are left as they were.
ContactSummary simd_pair_forces_fused(const Particles& p, const Scene& scene,
                                      const NeighborList& list,
                                      std::span<const LanePairConstants> constants,
                                      const BondingCriterion& criterion_met, PairForces& out,
                                      PairHistory& history, const FusedRing& ring,
                                      std::size_t first_row, std::size_t end_row,
                                      const SweepRecords& records,
                                      const std::function<void(std::size_t, std::size_t)>& done);
}  // namespace bondem
