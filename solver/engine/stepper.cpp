#include "solver/engine/stepper.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "solver/engine/parallel_sort.hpp"
#include "solver/models/energy.hpp"

namespace bondem {

Stepper::Stepper(Scene& scene, PairFlag pair_flag)
    : scene_(scene), pair_flag_(std::move(pair_flag)) {
  start();
  for (const std::int64_t id : scene_.particles.id) next_id_ = std::max(next_id_, id + 1);
}

Stepper::Stepper(Scene& scene, const RunShare& share, PairFlag pair_flag)
    : scene_(scene), pair_flag_(std::move(pair_flag)) {
  counted_ids_ = share.counted_ids;
  share_only_ = true;  // marked once the list has put the particles in order
  start();
  next_id_ = share.next_particle_id;
}

void Stepper::start() {
  if (scene_.needs_pair_flag() && !pair_flag_) {
    throw std::invalid_argument("bond criterion 'pair flag' needs a pair-flag supplier");
  }
  if (simd_pass_applies(scene_)) lane_constants_ = lane_pair_constants(scene_);
  list_.build(scene_.particles, scene_.domain, list_reach(), scene_.reorder_interval > 0);
  mark_counted();
  // An initial state's pairs keep their springs and bonds; a fresh scene has none.
  carry_pairs(carried_from(scene_.initial_pairs));
  scene_.initial_pairs = std::vector<SlipRecord>{};
  build_boundary_candidates(scene_, boundary_candidates_);
  compute_forces(std::numeric_limits<double>::quiet_NaN());
  bonds_formed_ = static_cast<std::int64_t>(contacts_.bonds_formed);
  streams_.assign(scene_.streams.size(), ParticleTally{});
}

Stepper::Stepper(Scene& scene, StepperState restored, PairFlag pair_flag)
    : Stepper(scene, std::move(restored), CarriedPairs{}, std::move(pair_flag)) {}

Stepper::Stepper(Scene& scene, StepperState restored, CarriedPairs carried, PairFlag pair_flag)
    : scene_(scene), pair_flag_(std::move(pair_flag)) {
  if (scene_.needs_pair_flag() && !pair_flag_) {
    throw std::invalid_argument("bond criterion 'pair flag' needs a pair-flag supplier");
  }
  if (simd_pass_applies(scene_)) lane_constants_ = lane_pair_constants(scene_);
  // Forces come with the particles: they were evaluated with the half-step velocities of the
  // interrupted step, which a fresh evaluation could not reproduce.
  list_.restore(scene_.particles, scene_.domain, list_reach(), restored.list);
  // Freed before the pair slots are allocated: a restart's peak stays at a step's.
  restored.list = NeighborListState{};
  CarriedPairs records = carried_from(restored.slips);
  restored.slips = std::vector<SlipRecord>{};
  carry_pairs(std::move(carried), std::move(records), restored.slip_source);
  restored.slip_source = {};  // closes a checkpoint it reads
  if (restored.boundaries.size() != kBoundaryStateValues * scene_.boundaries.size()) {
    throw std::invalid_argument("saved state does not match the case's boundaries");
  }
  for (std::size_t b = 0; b < scene_.boundaries.size(); ++b) {
    Boundary& boundary = scene_.boundaries[b];
    const double* saved = &restored.boundaries[kBoundaryStateValues * b];
    for (int a = 0; a < 3; ++a) {
      boundary.center[a] = saved[a];
      boundary.velocity[a] = saved[3 + a];
    }
    boundary.angle = saved[6];
    boundary.angular_velocity = saved[7];
  }
  // Gathered afresh: the lists only narrow the search, so where they were gathered does not
  // change a result (boundary_candidates.hpp).
  build_boundary_candidates(scene_, boundary_candidates_);
  contacts_ = restored.contacts;
  time_ = restored.time;
  step_count_ = restored.step;
  bonds_formed_ = restored.bonds_formed;
  bonds_broken_ = restored.bonds_broken;
  laser_energy_ = restored.laser_energy;
  laser_missed_ = restored.laser_missed;
  if (restored.streams.size() != scene_.streams.size()) {
    throw std::invalid_argument("saved state does not match the case's streams");
  }
  streams_ = std::move(restored.streams);
  next_id_ = restored.next_particle_id;
  removed_ = restored.removed;
}

bool Stepper::takes_fused_pass() {
  const Particles& p = scene_.particles;
  const std::size_t n = p.size();
  // It keeps no force slots: a run whose output reads each pair's force (a VTK frame does) takes
  // the two passes. Without a drift ahead it still pays.
  if (scene_.pair_forces_read || lane_constants_.empty() || !counted_.empty() || p.thermal() ||
      p.contact_history || scene_.rolling() || n < fused_pass_from() ||
      keeps_pair_records(n, scene_.friction, false, false)) {
    return false;
  }
  const int shares = threads_in_use(n);
  if (fused_plan_.builds != list_.build_count() || fused_plan_.particles != n ||
      fused_plan_.friction != scene_.friction || fused_plan_.shares != shares) {
    plan_fused_pass(list_, n, scene_.friction, shares, fused_plan_);
  }
  return fused_plan_.usable;
}

template <bool kFriction, class Law>
ContactSummary Stepper::evaluate_fused(const Law& law, bool ahead) {
  Particles& p = scene_.particles;
  const std::size_t n = p.size();
  const BondingCriterion criterion{p, pair_forces_.bonded, pair_flag_ ? &pair_flag_ : nullptr};
  boundary_frames_.clear();
  for (const Boundary& boundary : scene_.boundaries) boundary_frames_.push_back(frame_of(boundary));
  // The shares of the split every pass takes, without stealing: a share's rows must be done by
  // the thread whose ring holds their pairs.
  step_split_.prepare((n + kPairPassChunk - 1) / kPairPassChunk, threads_in_use(n));
  const int shares = step_split_.threads();
  fused_rows_.resize(static_cast<std::size_t>(shares) + 1);
  for (int s = 0; s <= shares; ++s) {
    fused_rows_[static_cast<std::size_t>(s)] = std::min(n, step_split_.begin(s) * kPairPassChunk);
  }
  cut_fused_pass(fused_plan_, list_, fused_rows_, fused_cuts_);
  const std::size_t stride = scene_.boundaries.size() * kBoundaryLoadValues;
  wall_loads_.assign(static_cast<std::size_t>(shares) * stride, ExactSum{});
  ahead_parts_.assign(static_cast<std::size_t>(shares), {});
  std::vector<ContactSummary> parts(static_cast<std::size_t>(shares));
  std::vector<double> seconds(static_cast<std::size_t>(shares), 0.0);
  // The kinematics records the lanes read where they read any: a particle's drift writes its
  // next ones only once no row still to be done reads it.
  const SweepRecords records = current_records(p, scene_.friction, lane_scratch_);
  const SweepArrays arrays = ahead ? sweep_arrays(true) : SweepArrays{};
  // Pass 2 of particles [first, end) from @p slots, on share @p s's sums, and their drift ahead.
  const auto sum = [&](int s, const auto& slots, std::size_t first, std::size_t end) {
    const auto share = static_cast<std::size_t>(s);
    const ContactSummary walls =
        gather_range<kFriction, false>(p, scene_, list_, boundary_candidates_, boundary_frames_,
                                       law, slots, wall_loads_.data() + share * stride, first, end);
    ContactSummary& part = parts[share];
    part.wall_contacts += walls.wall_contacts;
    part.max_overlap = std::max(part.max_overlap, walls.max_overlap);
    part.max_overlap_fraction = std::max(part.max_overlap_fraction, walls.max_overlap_fraction);
    if (ahead) {
      ahead_parts_[share].result.merge(closing_opening_sweep(arrays, scene_.time_step, first, end));
    }
  };
  const std::vector<std::uint32_t>& waiting = fused_cuts_.ranges;
  const auto share_pass = [&](int s) {
    const double start = omp_get_wtime();
    const auto share = static_cast<std::size_t>(s);
    const FusedRing ring = fused_ring(fused_plan_, fused_cuts_, s);
    const std::uint32_t mask = ring.pairs - 1;
    const RingRecords ring_records{ring.records, mask};
    const RingSlots ring_slots{{ring.slots[0], mask}, {ring.slots[1], mask}, {ring.slots[2], mask},
                               {ring.slots[3], mask}, {ring.slots[4], mask}, {ring.slots[5], mask},
                               {ring.slots[6], mask}};
    // The first range of waiting particles not wholly before the run.
    std::size_t next = 0;
    const ContactSummary pairs = simd_pair_forces_fused(
        p, scene_, list_, lane_constants_, criterion, pair_forces_, history_, ring,
        fused_rows_[share], fused_rows_[share + 1], records, [&](std::size_t row, std::size_t end) {
          for (std::size_t at = row; at < end;) {
            while (next < waiting.size() && waiting[next + 1] <= at) next += 2;
            if (next < waiting.size() && waiting[next] <= at) {
              at = std::min<std::size_t>(end, waiting[next + 1]);
              continue;
            }
            const std::size_t stop =
                next < waiting.size() ? std::min<std::size_t>(end, waiting[next]) : end;
            if (ring.records != nullptr) {
              sum(s, ring_records, at, stop);
            } else {
              sum(s, ring_slots, at, stop);
            }
            at = stop;
          }
        });
    add_pair_summary(parts[share], pairs);
    seconds[share] = omp_get_wtime() - start;
  };
  // The particles that waited for every share's pass 1, from the records it kept of their pairs:
  // the team's thread @p t of @p team takes its part of them in particle order.
  std::size_t waiting_count = 0;
  for (std::size_t r = 0; r < waiting.size(); r += 2) waiting_count += waiting[r + 1] - waiting[r];
  const KeptSlots kept(fused_cuts_.kept);
  const auto waiting_pass = [&](int t, int team) {
    const std::size_t from = waiting_count * static_cast<std::size_t>(t) / team;
    const std::size_t to = waiting_count * static_cast<std::size_t>(t + 1) / team;
    std::size_t before = 0;  // waiting particles in the ranges before r
    for (std::size_t r = 0; r < waiting.size() && before < to; r += 2) {
      const std::size_t size = waiting[r + 1] - waiting[r];
      const std::size_t first = waiting[r] + (std::max(from, before) - before);
      const std::size_t end = waiting[r] + (std::min(to, before + size) - before);
      if (first < end) sum(t, kept, first, end);
      before += size;
    }
  };
  if (shares == 1) {
    share_pass(0);
    waiting_pass(0, 1);
  } else {
#pragma omp parallel num_threads(shares)
    {
      const int team = omp_get_num_threads();
      const int me = omp_get_thread_num();
      for (int s = me; s < shares; s += team) share_pass(s);
#pragma omp barrier
      waiting_pass(me, team);
    }
    step_split_.add_pending(seconds, {});
  }
  ContactSummary summary;
  for (const ContactSummary& part : parts) {
    add_pair_summary(summary, part);
    summary.wall_contacts += part.wall_contacts;
  }
  // With a drift ahead every particle has drifted: a pair past the overlap limit ends the step
  // drifted, as a boundary past it does in the two passes.
  drifted_ = ahead;
  if (ahead) {
    ahead_sweep_ = SweepResult{};
    for (const SharedSweepResult& part : ahead_parts_) ahead_sweep_.merge(part.result);
    lane_scratch_.current = arrays.records != nullptr;
  }
  ++fused_evaluations_;
  return summary;
}

template <bool kFriction, bool kModels, class Law>
ContactSummary Stepper::evaluate_forces(const Law& law, bool ahead) {
  if constexpr (!kModels && std::is_same_v<Law, BondNormalLaw>) {
    if (fused_now_) return evaluate_fused<kFriction>(law, ahead);
  }
  const BondingCriterion criterion{scene_.particles, pair_forces_.bonded,
                                   pair_flag_ ? &pair_flag_ : nullptr};
  const std::uint8_t* counted = counted_.empty() ? nullptr : counted_.data();
  // The SIMD pass serves the runs whose every pair has a vector form (lane_constants_ is set).
  const bool lanes = !kModels && std::is_same_v<Law, BondNormalLaw> && !lane_constants_.empty();
  ContactSummary pairs =
      lanes
          ? simd_pair_forces(scene_.particles, scene_, list_, lane_constants_, criterion,
                             pair_forces_, history_, counted, &step_split_, &lane_scratch_)
          : compute_pair_forces<kFriction, kModels>(scene_.particles, scene_, list_, law, criterion,
                                                    pair_forces_, history_, counted, &step_split_);
  // The boundaries' frames at their poses of this step, into storage kept across steps.
  boundary_frames_.clear();
  for (const Boundary& boundary : scene_.boundaries) boundary_frames_.push_back(frame_of(boundary));
  // A pair past the overlap limit ends the step with its closing kicks (complete_step): no
  // drift ahead then. A boundary past it is found in pass 2 itself, and its step ends drifted.
  drifted_ = ahead && pairs.max_overlap_fraction <= scene_.max_overlap_fraction;
  std::optional<LoadedRange> drift_ahead;
  SweepArrays arrays;
  if (drifted_) {
    arrays = sweep_arrays(true);
    const std::size_t n = scene_.particles.size();
    ahead_parts_.assign(static_cast<std::size_t>(std::max(threads_in_use(n), 1)), {});
    drift_ahead.emplace([&](int share, std::size_t first, std::size_t end) {
      ahead_parts_[static_cast<std::size_t>(share)].result.merge(
          closing_opening_sweep(arrays, scene_.time_step, first, end));
    });
  }
  const ContactSummary walls = gather_forces<kFriction, kModels>(
      scene_.particles, scene_, list_, boundary_candidates_, boundary_frames_, law, pair_forces_,
      wall_loads_, step_split_, counted, drift_ahead ? &*drift_ahead : nullptr);
  if (drifted_) {
    ahead_sweep_ = SweepResult{};
    for (const SharedSweepResult& part : ahead_parts_) ahead_sweep_.merge(part.result);
    lane_scratch_.current = arrays.records != nullptr;
  }
  pairs.wall_contacts = walls.wall_contacts;
  pairs.max_overlap = std::max(pairs.max_overlap, walls.max_overlap);
  pairs.max_overlap_fraction = std::max(pairs.max_overlap_fraction, walls.max_overlap_fraction);
  pairs.thermal_step_ratio = walls.thermal_step_ratio;
  return pairs;
}

void Stepper::compute_forces(double laser_time, bool ahead) {
  // The per-pair forces are sized for the list here, the first time they are needed after a
  // build or release_pair_forces(): a restored stepper that is only read (a checkpoint, the end
  // of a decomposed run) never holds them (56 B a pair, 64 B as records).
  const Particles& p = scene_.particles;
  const bool records = !lane_constants_.empty() && !p.contact_history &&
                       keeps_pair_records(p.size(), scene_.friction, scene_.rolling(), p.thermal());
  fused_now_ = takes_fused_pass();
  if (fused_now_) {
    // Its force slots are a ring per thread and the records of the pairs it keeps.
    if (pair_forces_.pairs() != 0) release_pair_forces();
  } else if (pair_forces_.pairs() != list_.pair_count() || pair_forces_.in_records() != records) {
    pair_forces_.resize(list_.pair_count(), scene_.friction, scene_.rolling(), p.thermal(),
                        records);
  }
  // Compiled per storage need: tangential springs (friction) and the contact history of cohesion
  // and EPSD rolling (Particles::contact_history); every other choice is the pair's, at run time.
  const bool models = scene_.particles.contact_history;
  contacts_ = with_normal_law(scene_.normal_law, [&](const auto& law) {
    if (scene_.friction) {
      return models ? evaluate_forces<true, true>(law, ahead)
                    : evaluate_forces<true, false>(law, ahead);
    }
    return models ? evaluate_forces<false, true>(law, ahead)
                  : evaluate_forces<false, false>(law, ahead);
  });
  deposit_laser(laser_time);
}

void Stepper::deposit_laser(double laser_time) {
  laser_power_ = laser_missed_power_ = 0.0;
  Particles& p = scene_.particles;
  // A share of a distributed run: its counted particles only, the columns agreed on (every share
  // takes part, with particles or without).
  const bool shared = share_only_ && laser_agreement_.has_value();
  if ((!p.thermal() && !shared) || !scene_.laser || !std::isfinite(laser_time)) return;
  // Serial, ties by id: the deposit depends on neither the thread count nor the particle order.
  const Domain& domain = scene_.domain;
  const LaserPeriods periods{domain.periodic[0] ? domain.length().x() : 0.0,
                             domain.periodic[1] ? domain.length().y() : 0.0};
  const std::uint8_t none = 0;  // a share with no particle still takes part in the agreement
  const std::uint8_t* counted = !shared ? nullptr : counted_.empty() ? &none : counted_.data();
  const LaserDeposit deposit =
      deposit_laser_heat(p.x.data(), p.y.data(), p.z.data(), p.radius.data(), p.id.data(), p.size(),
                         *scene_.laser, laser_time, p.heat_rate.data(), laser_scratch_, periods,
                         counted, shared ? &*laser_agreement_ : nullptr);
  laser_power_ = deposit.absorbed;
  laser_missed_power_ = deposit.missed;
}

std::uint64_t Stepper::slip_count() const {
  const auto pairs = static_cast<std::int64_t>(list_.pair_count());
  std::uint64_t count = 0;
  const bool parallel = pairs >= 4 * static_cast<std::int64_t>(kMinParallelParticles);
#pragma omp parallel for schedule(static) if (parallel) reduction(+ : count)
  for (std::int64_t k = 0; k < pairs; ++k) {
    count += carries_state(history_, pair_forces_.bonded, static_cast<std::uint32_t>(k)) ? 1 : 0;
  }
  return count;
}

std::vector<SlipRecord> Stepper::collect_slips() const {
  // Counted first: a vector grown by doubling would hold up to three times the records while it
  // moves them (72 B each, about three a particle in a frictional packing).
  const std::vector<std::uint32_t> rows = scene_.particles.order_by_id();
  std::size_t count = 0;
  for_each_slip(rows, [&count](const SlipRecord& /*slip*/) { ++count; });
  std::vector<SlipRecord> slips;
  slips.reserve(count);
  for_each_slip(rows, [&slips](const SlipRecord& slip) { slips.push_back(slip); });
  return slips;
}

Stepper::CarriedPairs Stepper::carried_from(const std::vector<SlipRecord>& slips) const {
  CarriedPairs carried;
  const bool extended = scene_.particles.contact_history;
  carried.history.resize(slips.size(), scene_.friction, extended);
  carried.bonded.resize(slips.size());
  carried.keys.reserve(slips.size());
  for (std::size_t s = 0; s < slips.size(); ++s) {
    const SlipRecord& slip = slips[s];
    carried.keys.push_back({slip.first_id, slip.second_id, static_cast<std::uint32_t>(s)});
    carried.bonded[s] = slip.bonded;
    if (scene_.friction) {
      carried.history.sx[s] = slip.sx;
      carried.history.sy[s] = slip.sy;
      carried.history.sz[s] = slip.sz;
    }
    if (extended) {
      carried.history.rx[s] = slip.rx;
      carried.history.ry[s] = slip.ry;
      carried.history.rz[s] = slip.rz;
      carried.history.joined[s] = slip.joined;
    }
  }
  return carried;
}

SlipRecord Stepper::CarriedPairs::record(std::size_t k) const {
  return slip_at(keys[k].first_id, keys[k].second_id, history, bonded, keys[k].slot);
}

Stepper::CarriedPairs Stepper::take_pairs(const std::vector<std::uint8_t>& keep_row) {
  return release_pairs(&keep_row);
}

void Stepper::release_pair_forces() {
  StaggeredVector<std::uint8_t> bonded = std::move(pair_forces_.bonded);
  pair_forces_ = PairForces{};
  pair_forces_.bonded = std::move(bonded);
}

Stepper::CarriedPairs Stepper::release_pairs(const std::vector<std::uint8_t>* rows) {
  CarriedPairs carried;
  release_pair_forces();
  carried.bonded = std::move(pair_forces_.bonded);
  carried.history = std::move(history_);
  history_ = PairHistory{};
  // Counted first, by contiguous shares of the rows, then each share fills its place on its own
  // thread: the keys in row order, their pages first written on every thread (at 10^6 particles
  // 72 MB, walked twice on one thread before).
  const StaggeredVector<std::uint32_t>& row_begin = list_.row_begins();
  const std::size_t n = list_.row_count();
  const int shares = threads_in_use(n);
  const auto share_rows = [&](int share, std::size_t& first, std::size_t& end) {
    first = n * static_cast<std::size_t>(share) / static_cast<std::size_t>(shares);
    end = n * static_cast<std::size_t>(share + 1) / static_cast<std::size_t>(shares);
  };
  const auto taken = [&](std::size_t i, std::uint32_t k) {
    return (rows == nullptr || (*rows)[i] != 0) &&
           carries_state(carried.history, carried.bonded, k);
  };
  std::vector<std::size_t> share_begin(static_cast<std::size_t>(shares) + 1, 0);
#pragma omp parallel for schedule(static, 1) num_threads(shares) if (shares > 1)
  for (int share = 0; share < shares; ++share) {
    std::size_t first = 0, end = 0, count = 0;
    share_rows(share, first, end);
    for (std::size_t i = first; i < end; ++i) {
      for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) count += taken(i, k) ? 1 : 0;
    }
    share_begin[static_cast<std::size_t>(share) + 1] = count;
  }
  for (std::size_t share = 0; share < static_cast<std::size_t>(shares); ++share) {
    share_begin[share + 1] += share_begin[share];
  }
  assign_zeros(carried.keys, share_begin.back());
  const Particles& p = scene_.particles;
#pragma omp parallel for schedule(static, 1) num_threads(shares) if (shares > 1)
  for (int share = 0; share < shares; ++share) {
    std::size_t first = 0, end = 0;
    share_rows(share, first, end);
    CarriedPairs::Key* key = carried.keys.data() + share_begin[static_cast<std::size_t>(share)];
    for (std::size_t i = first; i < end; ++i) {
      for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) {
        if (taken(i, k)) *key++ = {p.id[i], p.id[list_.second(k)], k};
      }
    }
  }
  return carried;
}

void Stepper::carry_pairs(CarriedPairs carried, CarriedPairs more, const SlipSource& streamed) {
  // Pair slots are indexed by the new list: start them clean, then refill by ids, the lowest
  // precedence first (each source overwrites what the one before set).
  const std::size_t pairs = list_.pair_count();
  const bool extended = scene_.particles.contact_history;
  history_.resize(pairs, scene_.friction, extended);
  assign_zeros(pair_forces_.bonded, pairs);
  if (streamed) fill_streamed_pairs(streamed);
  if (!carried.keys.empty() || !more.keys.empty()) {
    // Key each pair by its ids, smaller first; the springs belong to the first particle's side,
    // so they change sign when the list now sees the pair the other way round. By value:
    // std::minmax returns references, which would dangle here.
    const auto key = [](std::int64_t a, std::int64_t b) {
      return a < b ? std::pair<std::int64_t, std::int64_t>(a, b)
                   : std::pair<std::int64_t, std::int64_t>(b, a);
    };
    using Key = CarriedPairs::Key;
    // A total order (the slot breaks ties between records of one pair, if a source has two), so
    // that the sort's result, and the record each pair takes, depends on no thread count.
    for (CarriedPairs* source : {&carried, &more}) {
      sort_in_parallel(source->keys, [&](const Key& l, const Key& r) {
        const auto lk = key(l.first_id, l.second_id), rk = key(r.first_id, r.second_id);
        return lk != rk ? lk < rk : l.slot < r.slot;
      });
    }
    // Each row holds its pairs by their second particle's id, larger than its own (search_row,
    // sort_row_by_id): one search per row and source finds the keys with the row's id first,
    // sorted by the other id, and a walk along both matches them. Rows write disjoint slots.
    const Particles& p = scene_.particles;
    const StaggeredVector<std::uint32_t>& row_begin = list_.row_begins();
    const auto rows = static_cast<std::int64_t>(list_.row_count());
    const CarriedPairs* const sources[] = {&carried, &more};
    const bool parallel = rows >= static_cast<std::int64_t>(kMinParallelParticles);
#pragma omp parallel for schedule(static) if (parallel)
    for (std::int64_t row = 0; row < rows; ++row) {
      const auto i = static_cast<std::size_t>(row);
      if (row_begin[i] == row_begin[i + 1]) continue;
      const std::int64_t id = p.id[i];
      std::pair<const Key*, const Key*> found[2];  // each source's keys whose smaller id is id
      for (int s = 0; s < 2; ++s) {
        const StaggeredVector<Key>& keys = sources[s]->keys;
        const Key* const first = std::partition_point(
            keys.data(), keys.data() + keys.size(),
            [&](const Key& r) { return std::min(r.first_id, r.second_id) < id; });
        const Key* last = first;
        while (last != keys.data() + keys.size() && std::min(last->first_id, last->second_id) == id)
          ++last;
        found[s] = {first, last};
      }
      for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) {
        const std::int64_t other = p.id[list_.second(k)];
        for (int s = 0; s < 2; ++s) {
          auto& [at, end] = found[s];
          while (at != end && std::max(at->first_id, at->second_id) < other) ++at;
          if (at == end || std::max(at->first_id, at->second_id) != other) continue;
          const CarriedPairs& source = *sources[s];
          set_pair_slot(k, source.record(static_cast<std::size_t>(at - source.keys.data())),
                        at->first_id == id ? 1.0 : -1.0);
          break;  // the first source that holds the pair gives its state
        }
      }
    }
  }
  carried = CarriedPairs{};
  more = CarriedPairs{};
}

void Stepper::fill_streamed_pairs(const SlipSource& streamed) {
  const Particles& p = scene_.particles;
  std::vector<std::pair<std::int64_t, std::uint32_t>> index_of(p.size());
  for (std::size_t k = 0; k < p.size(); ++k) index_of[k] = {p.id[k], static_cast<std::uint32_t>(k)};
  std::sort(index_of.begin(), index_of.end());
  const auto local = [&](std::int64_t id) -> std::optional<std::uint32_t> {
    const auto found =
        std::lower_bound(index_of.begin(), index_of.end(), std::pair(id, std::uint32_t{0}));
    if (found == index_of.end() || found->first != id) return std::nullopt;
    return found->second;
  };
  const StaggeredVector<std::uint32_t>& row_begin = list_.row_begins();
  // The slots of the pair in the row of @p first whose second is @p second.
  const auto fill_row = [&](std::uint32_t first, std::uint32_t second, const SlipRecord& record,
                            double sign) {
    for (std::uint32_t k = row_begin[first]; k < row_begin[first + 1]; ++k) {
      if (list_.second(k) == second) set_pair_slot(k, record, sign);
    }
  };
  streamed([&](const SlipRecord& record) {
    const std::optional<std::uint32_t> i = local(record.first_id);
    const std::optional<std::uint32_t> j = local(record.second_id);
    if (!i || !j) return;
    fill_row(*i, *j, record, 1.0);
    if (*i != *j) fill_row(*j, *i, record, -1.0);
  });
}

void Stepper::set_pair_slot(std::uint32_t k, const SlipRecord& record, double sign) {
  pair_forces_.bonded[k] = record.bonded;
  if (scene_.friction) {
    history_.sx[k] = sign * record.sx;
    history_.sy[k] = sign * record.sy;
    history_.sz[k] = sign * record.sz;
  }
  if (scene_.particles.contact_history) {
    history_.rx[k] = sign * record.rx;
    history_.ry[k] = sign * record.ry;
    history_.rz[k] = sign * record.rz;
    history_.joined[k] = record.joined;
  }
}

void Stepper::rebuild_list() {
  const bool reorder =
      scene_.reorder_interval > 0 && (list_.build_count() % scene_.reorder_interval) == 0;
  lane_scratch_.current = false;  // the particles are about to move in memory
  CarriedPairs carried = release_pairs();
  if (scene_.domain.remove_outside) remove_outside();
  list_.build(scene_.particles, scene_.domain, list_reach(), reorder);
  mark_counted();  // the particles may have moved
  carry_pairs(std::move(carried));
  build_boundary_candidates(scene_, boundary_candidates_);
}

void Stepper::move_boundaries(double dt) {
  for (Boundary& boundary : scene_.boundaries) move_boundary(boundary, time_, dt);
}

SweepArrays Stepper::sweep_arrays(bool write_records) {
  Particles& p = scene_.particles;
  // The SIMD pass's records, written by the sweep while each value is in a register: a sweep of
  // its own over eight arrays and a parallel region less per step.
  const SweepRecords records =
      write_records && !lane_constants_.empty()
          ? records_for_sweep(lane_scratch_, p.size(), scene_.friction, fused_now_)
          : SweepRecords{};
  const bool spin = scene_.friction;
  const bool tracked = p.displacement_tracked;
  return {.x = p.x.data(),
          .y = p.y.data(),
          .z = p.z.data(),
          .vx = p.vx.data(),
          .vy = p.vy.data(),
          .vz = p.vz.data(),
          .fx = p.fx.data(),
          .fy = p.fy.data(),
          .fz = p.fz.data(),
          .wx = spin ? p.wx.data() : nullptr,
          .wy = spin ? p.wy.data() : nullptr,
          .wz = spin ? p.wz.data() : nullptr,
          .tx = spin ? p.tx.data() : nullptr,
          .ty = spin ? p.ty.data() : nullptr,
          .tz = spin ? p.tz.data() : nullptr,
          .dx = tracked ? p.dx.data() : nullptr,
          .dy = tracked ? p.dy.data() : nullptr,
          .dz = tracked ? p.dz.data() : nullptr,
          .mass = p.mass.data(),
          .radius = p.radius.data(),
          .x0 = list_.build_positions(0).data(),
          .y0 = list_.build_positions(1).data(),
          .z0 = list_.build_positions(2).data(),
          // Only the counted particles' displacements: a decomposed run's ranks then agree on
          // the whole run's largest, however far their ghosts drift from their owners meanwhile.
          .counted = counted_.empty() ? nullptr : counted_.data(),
          .records = records.kinematics,
          .record_count = records.kinematics != nullptr ? p.size() : 0,
          .spin_records = records.spins};
}

double Stepper::drift(double dt, bool write_records) {
  move_boundaries(dt);
  // One sweep: the opening half-kicks, the drift and the list's displacement check each read and
  // write the same particle arrays, which at 10^6 particles come from memory every time. The
  // displacement gets the very increment the position gets, so it stays x - x0 up to rounding
  // and does not jump when the list wraps a coordinate across a periodic boundary.
  const SweepArrays arrays = sweep_arrays(write_records);
  const std::size_t n = scene_.particles.size();
  const std::size_t chunks = (n + kPairPassChunk - 1) / kPairPassChunk;
  // A contiguous run of chunks per thread, moved toward equal times (thread_split.hpp).
  step_split_.prepare(chunks, threads_in_use(n));
  const double largest_sq = step_split_.run(
      0.0,
      [&](int, std::size_t first_chunk, std::size_t end_chunk) {
        return opening_sweep(arrays, dt, first_chunk * kPairPassChunk,
                             std::min(n, end_chunk * kPairPassChunk));
      },
      [](double& largest, double part) { largest = std::max(largest, part); });
  lane_scratch_.current = arrays.records != nullptr;
  return largest_sq;
}

bool Stepper::finish_step(double dt) {
  Particles& p = scene_.particles;
  const std::size_t n = p.size();
  const SweepArrays arrays = sweep_arrays();
  const std::size_t chunks = (n + kPairPassChunk - 1) / kPairPassChunk;
  step_split_.prepare(chunks, threads_in_use(n));
  bool finite = step_split_.run(
      true,
      [&](int, std::size_t first_chunk, std::size_t end_chunk) {
        return closing_sweep(arrays, dt, first_chunk * kPairPassChunk,
                             std::min(n, end_chunk * kPairPassChunk));
      },
      [](bool& all_finite, bool part) { all_finite = all_finite && part; });
  if (p.thermal()) {
    // Forward Euler on m c_p dT/dt = sum Q with the flows of the temperatures at the step's start.
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) reduction(&& : finite)
    for (std::size_t i = 0; i < n; ++i) {
      p.temperature[i] += dt * p.heat_rate[i] * p.inv_heat_capacity[i];
      p.peak_temperature[i] = std::max(p.peak_temperature[i], p.temperature[i]);
      finite = finite && std::isfinite(p.temperature[i]);
    }
  }
  // Zero without a laser; a share of a distributed run that holds no particle counts it too.
  laser_energy_ += laser_power_ * dt;
  laser_missed_ += laser_missed_power_ * dt;
  return finite;
}

void Stepper::remove_outside() {
  Particles& p = scene_.particles;
  std::vector<std::uint32_t> kept;
  kept.reserve(p.size());
  ExactSum mass;  // the same bytes whatever the order of the particles
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (scene_.domain.outside({p.x[i], p.y[i], p.z[i]})) {
      ++removed_.count;
      mass.add(p.mass[i]);
    } else {
      kept.push_back(static_cast<std::uint32_t>(i));
    }
  }
  if (kept.size() < p.size()) removed_.mass += mass.value();
  // Their pairs' state is left behind by the carry, which finds pairs by ids.
  if (kept.size() < p.size()) p.permute(kept);
}

std::size_t Stepper::insert_from_streams(Particles& into, double time) {
  std::size_t added = 0;
  for (std::size_t k = 0; k < scene_.streams.size(); ++k) {
    added +=
        insert_due_particles(scene_.streams[k], k, time, step_count_ + 1, scene_.domain,
                             scene_.largest_radius, into, next_id_, streams_[k], scene_.boundaries);
  }
  return added;
}

bool Stepper::streams_due() const {
  for (std::size_t k = 0; k < scene_.streams.size(); ++k) {
    if (stream_due(scene_.streams[k], k, time_ + scene_.time_step, streams_[k])) return true;
  }
  return false;
}

std::size_t Stepper::insert_due_into(Particles& into) {
  return insert_from_streams(into, time_ + scene_.time_step);
}

void Stepper::step() {
  // Two particles moving toward each other close the gap by twice the largest displacement:
  // rebuild once that displacement exceeds half the skin.
  const double half_skin = 0.5 * scene_.skin;
  // Nothing touches the particles between this drift and the forces but a rebuild (which
  // clears the records), so the sweep may write the pair pass's records. The last step may
  // have taken this drift already (drift_ahead()).
  const double moved_sq = drifted_ ? ahead_sweep_.largest_sq : drift(scene_.time_step, true);
  drifted_ = false;
  complete_step(moved_sq > half_skin * half_skin, drift_ahead_);
}

double Stepper::move() {
  if (drifted_) throw std::logic_error("Stepper::move: drifted ahead; only step() continues");
  // A decomposed run refreshes its ghosts between move() and complete_step(): no records.
  return drift(scene_.time_step, false);
}

void Stepper::complete_step(bool rebuild) {
  complete_step(rebuild, false);
}

void Stepper::complete_step(bool rebuild, bool ahead) {
  const double dt = scene_.time_step;
  const bool inserted = insert_here_ && !scene_.streams.empty() &&
                        insert_from_streams(scene_.particles, time_ + dt) > 0;
  if (rebuild || inserted) {
    rebuild_list();
  } else if (boundary_moved_half_skin(scene_, boundary_candidates_)) {
    build_boundary_candidates(scene_, boundary_candidates_);
  }
  // The laser deposits at mid-step, so a beam on for T seconds delivers its power for T seconds
  // to within one step.
  // Drifting ahead merges this step's closing kicks with the next one's opening kicks; a heat
  // step needs the closing kicks of its own step.
  compute_forces(time_ + 0.5 * dt, ahead && !scene_.particles.thermal());
  const bool overlap_exceeded = contacts_.max_overlap_fraction > scene_.max_overlap_fraction;
  // A step that blows up here ends with its closing kicks given: drifted ahead (a boundary past
  // the limit), with the next step's opening ones.
  const bool finite = drifted_ ? ahead_sweep_.finite : finish_step(dt);
  step_split_.rebalance_pending();
  bonds_formed_ += static_cast<std::int64_t>(contacts_.bonds_formed);
  bonds_broken_ += static_cast<std::int64_t>(contacts_.bonds_broken);
  time_ = static_cast<double>(++step_count_) * dt;
  // The boundaries' motion of the next step, as its drift() would begin with.
  if (drifted_) move_boundaries(dt);
  if (!finite || overlap_exceeded) throw diagnose_blow_up(finite);
  if (contacts_.thermal_step_ratio > 1.0) {
    std::ostringstream message;
    message << "step " << step_count_ << " (t = " << time_
            << " s): the explicit heat step is unstable, dt sum(H) / (m c_p) = "
            << contacts_.thermal_step_ratio << " > 1 for some particle; reduce time.step to "
            << dt / contacts_.thermal_step_ratio
            << " s or below (or raise specific_heat, lower thermal_conductivity)";
    throw BlowUpError(message.str(), BlowUpCause::kHeat);
  }
}

BlowUpError Stepper::diagnose_blow_up(bool finite) const {
  const Particles& p = scene_.particles;
  constexpr int kShownIds = 5;
  std::ostringstream message;
  message << "step " << step_count_ << " (t = " << time_ << " s): ";
  if (!finite) {
    // Name the particles and what is not finite about them: motion, or temperature.
    const auto list_ids = [&](const char* what, auto non_finite) {
      int shown = 0;
      std::size_t count = 0;
      std::ostringstream ids;
      for (std::size_t i = 0; i < p.size(); ++i) {
        if (!non_finite(i)) continue;
        if (shown < kShownIds) ids << (shown++ ? ", " : " ") << p.id[i];
        ++count;
      }
      if (count == 0) return false;
      message << "non-finite " << what << " of " << count << " particle(s), id" << ids.str()
              << (count > static_cast<std::size_t>(shown) ? ", ..." : "");
      return true;
    };
    const bool motion = list_ids("position or velocity", [&](std::size_t i) {
      return !std::isfinite(p.vx[i] + p.vy[i] + p.vz[i] + p.x[i] + p.y[i] + p.z[i]);
    });
    if (p.thermal()) {
      if (motion) message << "; ";
      const bool heat =
          list_ids("temperature", [&](std::size_t i) { return !std::isfinite(p.temperature[i]); });
      if (heat && !motion) return BlowUpError(message.str(), BlowUpCause::kHeat);
    }
    return BlowUpError(message.str());
  }
  message << "an overlap exceeds " << scene_.max_overlap_fraction
          << " of the smaller radius (largest: " << contacts_.max_overlap_fraction << ")";
  if (std::optional<BlowUpError> pair = diagnose_deep_pair(message)) return *pair;
  return diagnose_deep_boundary(message);
}

std::optional<BlowUpError> Stepper::diagnose_deep_pair(std::ostringstream& message) const {
  const Particles& p = scene_.particles;
  // The first pair past the limit, and a tool touching either particle (the likely driver).
  std::optional<std::pair<std::size_t, std::size_t>> deepest;
  list_.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    const double overlap =
        pair_overlap(p.radius[i], p.radius[j], list_.separation(p, i, j, k).norm());
    if (overlap > scene_.max_overlap_fraction * std::min(p.radius[i], p.radius[j])) {
      deepest.emplace(i, j);
      return false;
    }
    return true;
  });
  if (!deepest) return std::nullopt;
  const auto [i, j] = *deepest;
  message << "; particle ids " << p.id[i] << " and " << p.id[j];
  for (const std::size_t m : {i, j}) {
    const Eigen::Vector3d centre(p.x[m], p.y[m], p.z[m]);
    for (const Boundary& boundary : scene_.boundaries) {
      if (boundary.motion.moves() && !surely_apart(boundary, centre, p.radius[m])) {
        message << " (id " << p.id[m] << " touched by tool '" << boundary.name << "')";
        return BlowUpError(message.str(), BlowUpCause::kTool);
      }
    }
  }
  return BlowUpError(message.str());
}

BlowUpError Stepper::diagnose_deep_boundary(std::ostringstream& message) const {
  const Particles& p = scene_.particles;
  // A particle in a boundary: name a moving one (a tool) first, as a tool pressing a particle
  // into a wall is the likely driver of both overlaps.
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double limit = scene_.max_overlap_fraction * p.radius[i];
    const Eigen::Vector3d centre(p.x[i], p.y[i], p.z[i]);
    const Boundary* touching_tool = nullptr;
    for (const Boundary& boundary : scene_.boundaries) {
      if (!boundary.motion.moves() || surely_apart(boundary, centre, p.radius[i])) continue;
      touching_tool = &boundary;
      if (p.radius[i] - nearest_surface(boundary, centre).gap > limit) {
        message << "; particle id " << p.id[i] << " in tool '" << boundary.name << "' (moving at "
                << boundary.velocity.norm() << " m/s)";
        return BlowUpError(message.str(), BlowUpCause::kTool);
      }
    }
    for (const Boundary& boundary : scene_.boundaries) {
      if (boundary.motion.moves() || surely_apart(boundary, centre, p.radius[i])) continue;
      if (p.radius[i] - nearest_surface(boundary, centre).gap > limit) {
        message << "; particle id " << p.id[i] << " in wall '" << boundary.name << "'";
        if (touching_tool == nullptr) return BlowUpError(message.str());
        message << ", pressed by tool '" << touching_tool->name << "'";
        return BlowUpError(message.str(), BlowUpCause::kTool);
      }
    }
  }
  return BlowUpError(message.str());
}

StepperState Stepper::save_state(SavedArrays arrays) const {
  if (drifted_) {
    throw std::logic_error("Stepper::save_state: drifted ahead; only step() continues");
  }
  StepperState state;
  state.time = time_;
  state.step = step_count_;
  state.contacts = contacts_;
  if (arrays == SavedArrays::kIncluded) {
    list_.save(state.list);
    state.slips = collect_slips();
  } else {
    state.list.builds = list_.build_count();
  }
  state.bonds_formed = bonds_formed_;
  state.bonds_broken = bonds_broken_;
  state.laser_energy = laser_energy_;
  state.laser_missed = laser_missed_;
  state.streams = streams_;
  state.next_particle_id = next_id_;
  state.removed = removed_;
  for (const Boundary& boundary : scene_.boundaries) {
    for (int a = 0; a < 3; ++a) state.boundaries.push_back(boundary.center[a]);
    for (int a = 0; a < 3; ++a) state.boundaries.push_back(boundary.velocity[a]);
    state.boundaries.push_back(boundary.angle);
    state.boundaries.push_back(boundary.angular_velocity);
  }
  return state;
}

std::vector<ExactSum> Stepper::boundary_load_sums() const {
  const std::size_t stride = scene_.boundaries.size() * kBoundaryLoadValues;
  if (stride == 0 || wall_loads_.empty() || wall_loads_.size() % stride != 0) {
    return {};  // not evaluated yet
  }
  // The threads' exact sums merged: the same bytes for any thread count and particle order.
  std::vector<ExactSum> merged(wall_loads_.begin(), wall_loads_.begin() + stride);
  for (std::size_t t = 1; t < wall_loads_.size() / stride; ++t) {
    for (std::size_t v = 0; v < stride; ++v) merged[v] += wall_loads_[t * stride + v];
  }
  return merged;
}

std::vector<BoundaryLoad> boundary_loads_of(const std::vector<ExactSum>& sums) {
  std::vector<BoundaryLoad> totals(sums.size() / kBoundaryLoadValues);
  for (std::size_t b = 0; b < totals.size(); ++b) {
    const ExactSum* f = &sums[b * kBoundaryLoadValues];
    // The reaction on the boundary; subtracted from zero, so that no load reads -0.
    totals[b].force -= Eigen::Vector3d(f[0].value(), f[1].value(), f[2].value());
    totals[b].moment -= Eigen::Vector3d(f[3].value(), f[4].value(), f[5].value());
  }
  return totals;
}

ExactSum Stepper::kinetic_energy_sum() const {
  const Particles& p = scene_.particles;
  ExactSum energy;  // exact: the same bytes whatever the order of the particles
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!counted_.empty() && counted_[i] == 0) continue;
    energy.add(translational_energy(p.mass[i], p.vx[i], p.vy[i], p.vz[i]));
  }
  return energy;
}

ExactSum Stepper::rotational_energy_sum() const {
  const Particles& p = scene_.particles;
  ExactSum energy;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!counted_.empty() && counted_[i] == 0) continue;
    energy.add(bondem::rotational_energy(p.inverse_inertia(i), p.wx[i], p.wy[i], p.wz[i]));
  }
  return energy;
}

void Stepper::count_only(std::vector<std::int64_t> owned_ids) {
  counted_ids_ = std::move(owned_ids);
  share_only_ = true;  // even with no id: a rank that owns nothing counts nothing
  mark_counted();
}

void Stepper::mark_counted() {
  if (!share_only_) {
    counted_.clear();
    return;
  }
  const Particles& p = scene_.particles;
  counted_.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    counted_[i] = std::binary_search(counted_ids_.begin(), counted_ids_.end(), p.id[i]) ? 1 : 0;
  }
}

}  // namespace bondem
