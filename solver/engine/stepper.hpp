#pragma once
/// @file stepper.hpp
/// Velocity-Verlet time stepping of a scene: neighbors -> forces -> integrate.

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "solver/engine/boundary_candidates.hpp"
#include "solver/engine/contact_kernel.hpp"
#include "solver/engine/exact_sum.hpp"
#include "solver/engine/fused_pass.hpp"
#include "solver/engine/neighbor_list.hpp"
#include "solver/engine/pair_kernel_simd.hpp"
#include "solver/engine/particle_sweeps_simd.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/slip_record.hpp"

namespace bondem {

/// What a blow-up is attributed to, so that the advice printed with it can fit.
enum class BlowUpCause {
  kContacts,  ///< overlaps or non-finite motion with no tool involved
  kTool,      ///< a particle driven into another, a wall or the tool itself by a moving tool
  kHeat,      ///< the explicit heat step, or a non-finite temperature
  kHistory,   ///< a non-finite total (energy, load) while every particle value was finite
};

/// A run that left the physics: non-finite values or an overlap beyond the scene's limit.
class BlowUpError : public std::runtime_error {
 public:
  explicit BlowUpError(const std::string& what, BlowUpCause cause = BlowUpCause::kContacts)
      : std::runtime_error(what), cause_(cause) {}
  /// What the blow-up is attributed to.
  BlowUpCause cause() const { return cause_; }

 private:
  BlowUpCause cause_;
};

/// The load the particles put on one boundary.
struct BoundaryLoad {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< [N]
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  ///< about Boundary::center [N m]
};

/// The loads of boundary_load_sums() @p sums (the reaction: minus the sums, never -0).
std::vector<BoundaryLoad> boundary_loads_of(const std::vector<ExactSum>& sums);

/// Values of one boundary in StepperState::boundaries.
inline constexpr std::size_t kBoundaryStateValues = 8;

/// Everything besides the particle arrays that a restarted stepper needs to continue bit for bit.
struct StepperState {
  double time = 0.0;
  std::int64_t step = 0;
  ContactSummary contacts;
  NeighborListState list;
  std::vector<SlipRecord> slips;  ///< springs and bond flags of the pairs in contact
  /// When set, visits further pairs' records, read as the restoring stepper takes them (a
  /// checkpoint's, read_checkpoint() with pairs_streamed): they need no room beside its pair slots.
  SlipSource slip_source;
  /// Pose of every boundary, kBoundaryStateValues each: centre, velocity, angle, angular velocity.
  std::vector<double> boundaries;
  std::int64_t bonds_formed = 0;       ///< bonds formed so far
  std::int64_t bonds_broken = 0;       ///< bonds lost so far
  double laser_energy = 0.0;           ///< laser energy absorbed by particles so far [J]
  double laser_missed = 0.0;           ///< absorbable laser energy that found no particle [J]
  std::vector<ParticleTally> streams;  ///< what each of the scene's streams inserted so far
  ParticleTally removed;  ///< particles removed outside the domain so far, and their mass
  std::int64_t next_particle_id = 0;  ///< id of the next particle a stream inserts
};

/// Whether Stepper::save_state() copies the arrays of the state.
enum class SavedArrays { kIncluded, kOmitted };

/// A process's share of a fresh decomposed run: see Stepper(Scene&, const RunShare&).
struct RunShare {
  std::vector<std::int64_t> counted_ids;  ///< sorted
  std::int64_t next_particle_id = 0;
};

/// Advances a scene in time. Owns the neighbor list and per-pair force slots; the scene owns the
/// particles. OpenMP-parallel; the state after any number of steps is the same bytes for any
/// thread count.
class Stepper {
 public:
  /// Pair flag for BondCriterion::kPairFlag, called with the particles' stable ids.
  using PairFlag = std::function<bool(std::int64_t id_i, std::int64_t id_j)>;

  /// Prepare to step @p scene: builds the neighbor list and evaluates the initial forces.
  explicit Stepper(Scene& scene, PairFlag pair_flag = {});
  /// As Stepper(scene) for a process's part of a decomposed run, counting only the particles of
  /// @p share.counted_ids from the initial forces on (count_only()); a stream's next particle
  /// takes @p share.next_particle_id (the part does not hold the whole run's largest id).
  Stepper(Scene& scene, const RunShare& share, PairFlag pair_flag = {});

  /// The pairs' state on its way across a list build (reordering included) or from a checkpoint:
  /// the pairs that have any, keyed by particle ids, each with its slot in the arrays it came
  /// from. 24 B a pair besides those arrays, which a rebuild moves out of the stepper rather than
  /// copies: no 72-B SlipRecord per loaded pair.
  struct CarriedPairs {
    struct Key {
      std::int64_t first_id, second_id;
      std::uint32_t slot;
    };
    StaggeredVector<Key> keys;
    PairHistory history;                   ///< springs, rolling springs and JKR flags, by slot
    StaggeredVector<std::uint8_t> bonded;  ///< bond flags, by slot
    /// The state of the pair of key @p k, as a checkpoint carries it.
    SlipRecord record(std::size_t k) const;
  };
  /// Continue from a saved state; the scene's particles (forces included) must be those saved
  /// with it. By value: its arrays are freed as soon as they are used (pass it moved).
  Stepper(Scene& scene, StepperState restored, PairFlag pair_flag = {});
  /// The same, the pairs' state from @p carried (take_pairs() of the stepper this one follows)
  /// and from restored.slips, which hold the pairs @p carried lacks.
  Stepper(Scene& scene, StepperState restored, CarriedPairs carried, PairFlag pair_flag = {});

  /// Take the state of the pairs whose first particle (the first of the pair's row, as
  /// for_each_slip() visits it) @p keep_row marks, by its index in the scene's particles, out of
  /// the stepper, which steps no more: what a decomposed run's migration carries to the part that
  /// follows, in the stepper's arrays (about 49 B a pair with a spring) instead of 72-B
  /// SlipRecords.
  CarriedPairs take_pairs(const std::vector<std::uint8_t>& keep_row);

  /// One velocity-Verlet step of scene.time_step. Throws BlowUpError, after completing the step,
  /// when a value is not finite or an overlap exceeds scene.max_overlap_fraction of a radius.
  /// Equal to complete_step(move() > (skin / 2)^2), bit for bit; its drift also writes the SIMD
  /// pass's kinematics records, which move() leaves to the pass (ghosts change in between).
  /// After a step that drifted ahead (drift_ahead()) it starts from that drift.
  void step();

  /// The first half of step(): the opening half-kicks and the drift. Returns the largest squared
  /// displacement of a particle (a counted one: count_only()) since the last list build, so that
  /// the parts of a decomposed run can agree on a rebuild before any of them takes it.
  double move();
  /// The second half of step(): the particles the streams owe, the list rebuilt when @p rebuild
  /// or a particle was inserted, the forces, the closing half-kicks and the checks of step().
  void complete_step(bool rebuild);

  /// With @p ahead, the next step() (unless a heat step, or one with an overlap past the limit in
  /// its pairs) also gives its closing half-kicks, and the following step's opening half-kicks and
  /// drift, particle range by particle range as pass 2 completes their forces: those are then read
  /// from the caches instead of the memory, each particle array is read and written once per step
  /// instead of twice, and the sweep of the next step() is already done. The same operations in
  /// the same order, so the same bytes; but the state after that step is in the middle of the
  /// next one (drifted()), which only step() can complete: ask for it at steps whose end state
  /// nobody reads. A boundary past the overlap limit ends it drifted, and a non-finite value the
  /// merged sweep finds throws the BlowUpError of the step it closes. Measured (bench_step,
  /// BM_Step_DriftAheadPaired, runs of eight steps, seven of them drifting ahead, against eight
  /// settled ones): 0.90 of the time per step at 997 477 spheres on one thread, 0.89 on two, 0.95
  /// at 20 800. Off by default.
  void drift_ahead(bool ahead) { drift_ahead_ = ahead; }
  /// Whether the last step() took the next one's opening kicks and drift (drift_ahead()): until
  /// the next step(), positions are those of the next step's forces.
  bool drifted() const { return drifted_; }
  /// How many force evaluations took the fused pass (fused_pass.hpp) so far.
  std::int64_t fused_evaluations() const { return fused_evaluations_; }

  /// The state to checkpoint together with the particles. With @p arrays kOmitted, the list's
  /// build positions and the pairs' state (StepperState::list.x0..z0 and slips) are left empty: a
  /// writer then streams them from neighbors() and for_each_slip() instead of holding a copy
  /// (24 B a particle and 72 B a pair with a spring).
  StepperState save_state(SavedArrays arrays = SavedArrays::kIncluded) const;

  /// Calls @p visit(const SlipRecord&) for every pair that carries state (a spring, an EPSD
  /// rolling spring, a JKR hold or a bond): what save_state() puts in slips. With @p rows the
  /// particles' order_by_id(), by (first id, second id), whatever the storage order.
  template <class Visit>
  void for_each_slip(std::span<const std::uint32_t> rows, Visit&& visit) const;
  /// How many pairs for_each_slip() visits over every row, counted without building the records.
  std::uint64_t slip_count() const;

  /// Free the per-pair forces, torque terms and heat flows of the last evaluation (56 B a pair
  /// with friction; pair_forces() keeps only the bond flags) until the next step() evaluates them
  /// again: the end of a run reads the state, the list, the springs and the bond flags, not
  /// those, and its analysis then needs no memory beyond a step's.
  void release_pair_forces();

  /// Simulated time [s].
  double time() const { return time_; }
  /// Steps taken.
  std::int64_t step_count() const { return step_count_; }
  /// Contacts seen by the last force evaluation.
  const ContactSummary& contacts() const { return contacts_; }
  /// The current neighbor list (for analysis and output).
  const NeighborList& neighbors() const { return list_; }
  /// Per-pair forces of the last evaluation, indexed like the neighbor list.
  const PairForces& pair_forces() const { return pair_forces_; }
  /// Tangential spring elongations, indexed like the neighbor list.
  const PairHistory& pair_history() const { return history_; }
  /// Load on each boundary (minus what it exerts on the particles): force, and moment about its
  /// reference point, from the last force evaluation, summed exactly (any order, any threads).
  std::vector<BoundaryLoad> boundary_loads() const {
    return boundary_loads_of(boundary_load_sums());
  }
  /// The exact sums behind boundary_loads(): kBoundaryLoadValues per boundary, the force of the
  /// boundary on the particles and its moment (empty before the first evaluation).
  std::vector<ExactSum> boundary_load_sums() const;
  /// Kinetic energy of translation [J].
  double kinetic_energy() const { return kinetic_energy_sum().value(); }
  /// Kinetic energy of rotation [J].
  double rotational_energy() const { return rotational_energy_sum().value(); }
  /// The exact sum behind kinetic_energy().
  ExactSum kinetic_energy_sum() const;
  /// The exact sum behind rotational_energy().
  ExactSum rotational_energy_sum() const;

  /// Count only the share of the particles of @p owned_ids (sorted) from now on: the pairs whose
  /// first particle (the smaller id) is one of them in contacts() and the bonds formed and broken,
  /// their boundary contacts in contacts() and boundary_loads(), their energies. A decomposed
  /// run's ranks thus count disjoint shares that add up to the whole run's figures; the largest
  /// overlaps still take every pair (a maximum over the ranks is the whole run's).
  void count_only(std::vector<std::int64_t> owned_ids);
  /// Per particle, 1 where it counts (count_only()); empty without count_only(): all count.
  const std::vector<std::uint8_t>& counted() const { return counted_; }
  /// With count_only(): the laser heats only the counted particles, the processes agreeing on
  /// its columns through @p agreement (deposit_laser_heat), so that each particle gets what the
  /// run in one process gives it and every process the same laser power.
  void share_laser(LaserAgreement agreement) { laser_agreement_ = std::move(agreement); }
  /// Leave the streams' insertion to the caller (insert_due_into()): a decomposed run's
  /// processes insert alike, each from the particles near the streams gathered from all, and the
  /// new particles then join their owners. The stepper keeps the streams' tallies and next id.
  void insert_elsewhere() { insert_here_ = false; }
  /// Whether some stream owes a particle by the end of the step under way (after move()).
  bool streams_due() const;
  /// What complete_step() inserts, into @p into (the particles near the streams' regions) rather
  /// than the scene's particles: the tallies and the next id advance alike. Returns the count.
  std::size_t insert_due_into(Particles& into);
  /// Bonds formed so far (a pair joining the adhesive branch of eq. 25).
  std::int64_t bonds_formed() const { return bonds_formed_; }
  /// Bonds lost so far (overlap back at delta_crit, the pair apart, or the criterion failing).
  std::int64_t bonds_broken() const { return bonds_broken_; }
  /// Laser energy absorbed by the particles so far [J].
  double laser_energy() const { return laser_energy_; }
  /// Absorbable laser energy that fell between the particles, on the substrate, so far [J].
  double laser_missed() const { return laser_missed_; }
  /// What each of the scene's streams inserted so far.
  const std::vector<ParticleTally>& streams() const { return streams_; }
  /// Particles removed so far for leaving the domain (Domain::remove_outside), and their mass.
  const ParticleTally& removed() const { return removed_; }

 private:
  /// The fresh constructors' work: the list, the initial pairs' state, the initial forces.
  void start();
  /// complete_step(), and with @p ahead the next step's opening sweep in pass 2 where it
  /// applies (drift_ahead()).
  void complete_step(bool rebuild, bool ahead);
  /// Forces (and heat flows) at the current positions; @p laser_time, when finite, is the time at
  /// which the laser deposits heat during this step. With @p ahead, also this step's closing
  /// and the next step's opening sweep where that applies (sets drifted_ when it does).
  void compute_forces(double laser_time, bool ahead = false);
  /// Both passes with the normal-force law @p law; returns what they saw, merged.
  template <bool kFriction, bool kModels, class Law>
  ContactSummary evaluate_forces(const Law& law, bool ahead);
  /// Whether this step's forces take the fused pass (fused_pass.hpp); plans it for the list.
  bool takes_fused_pass();
  /// Both passes, and with @p ahead the drift ahead, as the fused pass.
  template <bool kFriction, class Law>
  ContactSummary evaluate_fused(const Law& law, bool ahead);
  /// The laser's heat deposit of this step into p.heat_rate (thermal runs with a laser).
  void deposit_laser(double laser_time);
  /// The particle arrays of the sweeps (drift, finish_step), as they are now; with
  /// @p write_records, also the SIMD pass's kinematics records where the pass reads them.
  SweepArrays sweep_arrays(bool write_records = false);
  /// Every boundary moved by its motion over the step that starts now.
  void move_boundaries(double dt);
  /// Half kick and drift; returns the largest squared displacement since the last list build.
  /// With @p write_records, also the SIMD pass's kinematics records (LanePassScratch), for a
  /// force evaluation that follows with no other change to the particles.
  double drift(double dt, bool write_records);
  /// Insert into @p into what the scene's streams owe by @p time; returns the count.
  std::size_t insert_from_streams(Particles& into, double time);
  /// Second half kick and the heat step; returns whether every value stayed finite.
  bool finish_step(double dt);
  /// The per-pair state (springs, bond flags) of the pairs that have any, keyed by particle ids:
  /// what a checkpoint carries (save_state()).
  std::vector<SlipRecord> collect_slips() const;
  /// Slot @p k of @p history and @p bonded as the record of the pair (@p first_id, @p second_id):
  /// springs when the history holds them (friction), rolling springs and the JKR flag when it
  /// holds those.
  static SlipRecord slip_at(std::int64_t first_id, std::int64_t second_id,
                            const PairHistory& history, const StaggeredVector<std::uint8_t>& bonded,
                            std::uint32_t k) {
    SlipRecord slip{first_id, second_id, 0.0, 0.0, 0.0};
    slip.bonded = bonded[k];
    if (!history.sx.empty()) {
      slip.sx = history.sx[k];
      slip.sy = history.sy[k];
      slip.sz = history.sz[k];
    }
    if (!history.joined.empty()) {
      slip.rx = history.rx[k];
      slip.ry = history.ry[k];
      slip.rz = history.rz[k];
      slip.joined = history.joined[k];
    }
    return slip;
  }
  /// for_each_slip's visit of pair @p k in the row of particle @p i.
  template <class Visit>
  void visit_slip(std::size_t i, std::uint32_t k, Visit& visit) const;
  /// @p slips (a checkpoint's) as carried pairs.
  CarriedPairs carried_from(const std::vector<SlipRecord>& slips) const;
  /// Take the pairs' state out of the stepper before a build: its history and bond flags move
  /// into the result, and the per-pair forces, torque terms and heat flows, which the evaluation
  /// after every build rewrites, are freed (56 B a pair with friction) for the keys to take
  /// their place. With @p rows, only the pairs in the rows it marks (by the row's particle index).
  CarriedPairs release_pairs(const std::vector<std::uint8_t>* rows = nullptr);
  /// Clean pair slots for the current list, refilled from @p carried by particle ids (then from
  /// @p more, then from @p streamed, for the pairs the former lack); the force slots are
  /// allocated once all are freed, so that a rebuild's peak stays below a step's.
  void carry_pairs(CarriedPairs carried, CarriedPairs more = {}, const SlipSource& streamed = {});
  /// Fill the pair slots of the current list from the records @p streamed visits, each found by
  /// its particles' ids (a record of a particle not here is passed over).
  void fill_streamed_pairs(const SlipSource& streamed);
  /// Pair slot @p k from @p record, its springs seen from the first particle of the slot's pair
  /// (@p sign -1 when the record names the pair the other way round).
  void set_pair_slot(std::uint32_t k, const SlipRecord& record, double sign);
  /// Whether slot @p k of @p history and @p bonded holds state: a spring, an EPSD rolling spring,
  /// a JKR hold or a bond.
  bool carries_state(const PairHistory& history, const StaggeredVector<std::uint8_t>& bonded,
                     std::uint32_t k) const {
    const bool loaded =
        scene_.friction && (history.sx[k] != 0.0 || history.sy[k] != 0.0 || history.sz[k] != 0.0);
    const bool held = !history.joined.empty() && (history.joined[k] != 0 || history.rx[k] != 0.0 ||
                                                  history.ry[k] != 0.0 || history.rz[k] != 0.0);
    return loaded || held || bonded[k] != 0;
  }
  /// Rebuild the list (reordering the particles every reorder_interval builds), carrying the
  /// per-pair state over by ids; first remove the particles outside the domain when it says so.
  void rebuild_list();
  /// counted_ from counted_ids_ for the particles' current order.
  void mark_counted();
  /// Drop the particles outside the domain (Domain::remove_outside), counting them in removed_.
  void remove_outside();
  /// The list's reach beyond touching: the skin plus the range of contacts that outlive it.
  double list_reach() const { return scene_.skin + scene_.contact_range; }
  BlowUpError diagnose_blow_up(bool finite) const;
  /// Adds the pair past the overlap limit, and a tool touching it, to @p message.
  std::optional<BlowUpError> diagnose_deep_pair(std::ostringstream& message) const;
  /// Adds a particle in a wall or tool to @p message.
  BlowUpError diagnose_deep_boundary(std::ostringstream& message) const;

  Scene& scene_;
  PairFlag pair_flag_;
  NeighborList list_;
  PairForces pair_forces_;
  PairHistory history_;
  std::vector<ExactSum> wall_loads_;  ///< per share of step_split_ and boundary, last evaluation
  std::vector<BoundaryCandidates> boundary_candidates_;  ///< per boundary; gathered with every list
  std::vector<BoundaryFrame> boundary_frames_;           ///< per boundary, at the last evaluation
  /// Per material pair, the SIMD pass's constants; empty where the run takes the scalar pass
  /// (simd_pass_applies).
  std::vector<LanePairConstants> lane_constants_;
  LanePassScratch lane_scratch_;         ///< the SIMD pass's buffers, kept across steps
  FusedPlan fused_plan_;                 ///< the fused pass's, for the current build of the list
  std::vector<std::size_t> fused_rows_;  ///< the fused pass's shares' first rows, and n
  FusedCuts fused_cuts_;                 ///< its waiting particles and kept pairs
  bool fused_now_ = false;               ///< whether this evaluation takes it
  std::int64_t fused_evaluations_ = 0;   ///< fused_evaluations()
  /// The threads' shares of the particles, one split for every pass of a step (the sweeps, pass 1's
  /// rows, pass 2): a particle's data then stay in one core's caches from pass to pass. Moved
  /// once a step by the passes' summed cost per chunk (thread_split.hpp).
  ThreadSplit step_split_{ThreadSplit::Deferred{}};
  ContactSummary contacts_;
  double time_ = 0.0;
  std::int64_t step_count_ = 0;
  std::int64_t bonds_formed_ = 0;
  std::int64_t bonds_broken_ = 0;
  double laser_energy_ = 0.0;
  double laser_missed_ = 0.0;
  LaserScratch laser_scratch_;
  std::optional<LaserAgreement> laser_agreement_;  ///< share_laser()'s
  double laser_power_ = 0.0;                       ///< absorbed in the last evaluation [W]
  double laser_missed_power_ = 0.0;
  std::vector<std::int64_t> counted_ids_;  ///< count_only()'s ids, sorted
  bool share_only_ = false;                ///< count_only() was called
  bool insert_here_ = true;                ///< false after insert_elsewhere()
  bool drift_ahead_ = false;               ///< drift_ahead()
  bool drifted_ = false;                   ///< drifted()
  SweepResult ahead_sweep_;                ///< what the last step's drift ahead saw, merged
  /// Per share of step_split_: what its pieces of the drift ahead saw.
  struct alignas(64) SharedSweepResult {
    SweepResult result;
  };
  std::vector<SharedSweepResult> ahead_parts_;
  std::vector<std::uint8_t> counted_;   ///< per particle, from counted_ids_ at every build
  std::vector<ParticleTally> streams_;  ///< per scene stream
  std::int64_t next_id_ = 0;            ///< id of the next inserted particle
  ParticleTally removed_;               ///< particles removed outside the domain so far
};

template <class Visit>
void Stepper::for_each_slip(std::span<const std::uint32_t> rows, Visit&& visit) const {
  // Rows by the id of their particle, each row by partner id: by (first id, second id).
  const StaggeredVector<std::uint32_t>& row_begin = list_.row_begins();
  for (const std::uint32_t i : rows) {
    for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) visit_slip(i, k, visit);
  }
}

template <class Visit>
void Stepper::visit_slip(std::size_t i, std::uint32_t k, Visit& visit) const {
  if (!carries_state(history_, pair_forces_.bonded, k)) return;
  const Particles& p = scene_.particles;
  const SlipRecord slip = slip_at(p.id[i], p.id[list_.second(k)], history_, pair_forces_.bonded, k);
  visit(slip);
}

}  // namespace bondem
