// The stepper's sweeps in SIMD lanes (particle_sweeps_simd.hpp). Highway re-includes this file
// once per target (hwy/foreach_target.h), as pair_kernel_simd.cpp.
#include "solver/engine/particle_sweeps_simd.hpp"

#include <algorithm>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "solver/engine/particle_sweeps_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace bondem::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// Writes the spins of the lanes at @p i into SweepArrays::spin_records, if any.
template <class D>
HWY_INLINE void store_spin_records(D d, const SweepArrays& a, std::size_t i, hn::Vec<D> wx,
                                   hn::Vec<D> wy, hn::Vec<D> wz) {
  if (a.spin_records == nullptr) return;
  hn::StoreInterleaved4(wx, wy, wz, hn::Zero(d), d, a.spin_records + 4 * i);
}

/// w += (dt/2) T / (0.4 m r^2) for the lanes at @p i: Particles::inverse_inertia's
/// operations, then the kick.
template <class D>
HWY_INLINE void kick_spin_lanes(D d, const SweepArrays& a, hn::Vec<D> half_dt, std::size_t i) {
  const auto r = hn::LoadU(d, a.radius + i);
  const auto inertia = hn::Set(d, 0.4) * hn::LoadU(d, a.mass + i) * r * r;
  const auto kick = half_dt * (hn::Set(d, 1.0) / inertia);
  const auto wx = hn::LoadU(d, a.wx + i) + kick * hn::LoadU(d, a.tx + i);
  const auto wy = hn::LoadU(d, a.wy + i) + kick * hn::LoadU(d, a.ty + i);
  const auto wz = hn::LoadU(d, a.wz + i) + kick * hn::LoadU(d, a.tz + i);
  hn::StoreU(wx, d, a.wx + i);
  hn::StoreU(wy, d, a.wy + i);
  hn::StoreU(wz, d, a.wz + i);
  store_spin_records(d, a, i, wx, wy, wz);
}

/// v += (dt/2) F/m for the lanes at @p i.
template <class D>
HWY_INLINE void kick_lanes(D d, const SweepArrays& a, hn::Vec<D> half_dt, std::size_t i) {
  const auto kick = half_dt * (hn::Set(d, 1.0) / hn::LoadU(d, a.mass + i));
  hn::StoreU(hn::LoadU(d, a.vx + i) + kick * hn::LoadU(d, a.fx + i), d, a.vx + i);
  hn::StoreU(hn::LoadU(d, a.vy + i) + kick * hn::LoadU(d, a.fy + i), d, a.vy + i);
  hn::StoreU(hn::LoadU(d, a.vz + i) + kick * hn::LoadU(d, a.fz + i), d, a.vz + i);
}

/// Writes the lanes at @p i of SweepArrays::records, if any: the position and velocity the
/// opening sweep just stored, with the radius and mass.
template <class D>
HWY_INLINE void store_records(D d, const SweepArrays& a, std::size_t i, hn::Vec<D> x, hn::Vec<D> y,
                              hn::Vec<D> z, hn::Vec<D> vx, hn::Vec<D> vy, hn::Vec<D> vz) {
  if (a.records == nullptr) return;
  hn::StoreInterleaved4(x, y, z, hn::LoadU(d, a.radius + i), d, a.records + 4 * i);
  hn::StoreInterleaved4(vx, vy, vz, hn::LoadU(d, a.mass + i), d,
                        a.records + 4 * a.record_count + 4 * i);
}

/// The opening sweep for the lanes at @p i: returns their squared displacements since the
/// list's build (all lanes; the caller keeps the counted ones).
template <class D>
HWY_INLINE hn::Vec<D> open_lanes(D d, const SweepArrays& a, hn::Vec<D> dt, hn::Vec<D> half_dt,
                                 std::size_t i) {
  kick_lanes(d, a, half_dt, i);
  const auto vx = hn::LoadU(d, a.vx + i), vy = hn::LoadU(d, a.vy + i), vz = hn::LoadU(d, a.vz + i);
  const auto step_x = dt * vx;
  const auto step_y = dt * vy;
  const auto step_z = dt * vz;
  const auto x = hn::LoadU(d, a.x + i) + step_x;
  const auto y = hn::LoadU(d, a.y + i) + step_y;
  const auto z = hn::LoadU(d, a.z + i) + step_z;
  hn::StoreU(x, d, a.x + i);
  hn::StoreU(y, d, a.y + i);
  hn::StoreU(z, d, a.z + i);
  store_records(d, a, i, x, y, z, vx, vy, vz);
  if (a.dx != nullptr) {
    hn::StoreU(hn::LoadU(d, a.dx + i) + step_x, d, a.dx + i);
    hn::StoreU(hn::LoadU(d, a.dy + i) + step_y, d, a.dy + i);
    hn::StoreU(hn::LoadU(d, a.dz + i) + step_z, d, a.dz + i);
  }
  if (a.wx != nullptr) kick_spin_lanes(d, a, half_dt, i);
  const auto moved_x = x - hn::LoadU(d, a.x0 + i);
  const auto moved_y = y - hn::LoadU(d, a.y0 + i);
  const auto moved_z = z - hn::LoadU(d, a.z0 + i);
  return moved_x * moved_x + moved_y * moved_y + moved_z * moved_z;
}

/// Raises @p largest to the lanes of @p moved_sq that count (all without a.counted). A
/// comparison, as std::max in the scalar loop, not Max (whose NaN results differ by target); a
/// maximum is exact, so any lane order agrees.
template <class D>
HWY_INLINE hn::Vec<D> keep_largest(D d, const SweepArrays& a, hn::Vec<D> largest,
                                   hn::Vec<D> moved_sq, std::size_t i) {
  auto raise = moved_sq > largest;
  if (a.counted != nullptr) {
    HWY_ALIGN double counts[hn::MaxLanes(d)];
    for (std::size_t l = 0; l < hn::Lanes(d); ++l) counts[l] = a.counted[i + l];
    raise = hn::And(raise, hn::Load(d, counts) > hn::Zero(d));
  }
  return hn::IfThenElse(raise, moved_sq, largest);
}

/// The largest lane of @p v (exact: any order agrees).
template <class D>
HWY_INLINE double largest_lane(D d, hn::Vec<D> v) {
  HWY_ALIGN double lanes[hn::MaxLanes(d)];
  hn::Store(v, d, lanes);
  double largest = 0.0;
  for (std::size_t l = 0; l < hn::Lanes(d); ++l) largest = std::max(largest, lanes[l]);
  return largest;
}

double OpeningSweep(const SweepArrays& a, double dt, std::size_t first, std::size_t end) {
  // Whole vectors, then the rest one lane at a time: the same operations on one lane.
  const hn::ScalableTag<double> d;
  const hn::CappedTag<double, 1> d1;
  auto largest = hn::Zero(d);
  auto largest_1 = hn::Zero(d1);
  std::size_t i = first;
  for (; i + hn::Lanes(d) <= end; i += hn::Lanes(d)) {
    const auto moved_sq = open_lanes(d, a, hn::Set(d, dt), hn::Set(d, 0.5 * dt), i);
    largest = keep_largest(d, a, largest, moved_sq, i);
  }
  for (; i < end; ++i) {
    const auto moved_sq = open_lanes(d1, a, hn::Set(d1, dt), hn::Set(d1, 0.5 * dt), i);
    largest_1 = keep_largest(d1, a, largest_1, moved_sq, i);
  }
  return std::max(largest_lane(d, largest), largest_lane(d1, largest_1));
}

/// The closing sweep for the lanes at @p i; returns where the position and velocity are finite.
template <class D>
HWY_INLINE hn::Mask<D> close_lanes(D d, const SweepArrays& a, hn::Vec<D> half_dt, std::size_t i) {
  if (a.wx != nullptr) kick_spin_lanes(d, a, half_dt, i);
  kick_lanes(d, a, half_dt, i);
  const auto sum = hn::LoadU(d, a.vx + i) + hn::LoadU(d, a.vy + i) + hn::LoadU(d, a.vz + i) +
                   hn::LoadU(d, a.x + i) + hn::LoadU(d, a.y + i) + hn::LoadU(d, a.z + i);
  return hn::IsFinite(sum);
}

/// The closing sweep of the step before and the opening sweep of this one for the lanes at @p i,
/// but for the spins (close_open_spin_lanes): both half kicks by the same forces and the same
/// 1/m, each by the scalar formula's operations (so the bytes equal close_lanes then open_lanes),
/// in one pass over the arrays. Sets @p finite to where the closed step's position and velocity
/// are finite; returns the squared displacements as open_lanes. Written out rather than
/// close_lanes then open_lanes: calling those two took 1 076 perf samples against 611 on the
/// 20 800 lattice (1/m and 1/I divided twice, every array reloaded), the run 3 % slower.
template <class D>
HWY_INLINE hn::Vec<D> close_open_lanes(D d, const SweepArrays& a, hn::Vec<D> dt, hn::Vec<D> half_dt,
                                       std::size_t i, hn::Mask<D>& finite) {
  const auto kick = half_dt * (hn::Set(d, 1.0) / hn::LoadU(d, a.mass + i));
  const auto x = hn::LoadU(d, a.x + i), y = hn::LoadU(d, a.y + i), z = hn::LoadU(d, a.z + i);
  auto vx = hn::LoadU(d, a.vx + i) + kick * hn::LoadU(d, a.fx + i);
  auto vy = hn::LoadU(d, a.vy + i) + kick * hn::LoadU(d, a.fy + i);
  auto vz = hn::LoadU(d, a.vz + i) + kick * hn::LoadU(d, a.fz + i);
  finite = hn::IsFinite(vx + vy + vz + x + y + z);
  vx = vx + kick * hn::LoadU(d, a.fx + i);
  vy = vy + kick * hn::LoadU(d, a.fy + i);
  vz = vz + kick * hn::LoadU(d, a.fz + i);
  hn::StoreU(vx, d, a.vx + i);
  hn::StoreU(vy, d, a.vy + i);
  hn::StoreU(vz, d, a.vz + i);
  const auto step_x = dt * vx, step_y = dt * vy, step_z = dt * vz;
  const auto moved_to_x = x + step_x, moved_to_y = y + step_y, moved_to_z = z + step_z;
  hn::StoreU(moved_to_x, d, a.x + i);
  hn::StoreU(moved_to_y, d, a.y + i);
  hn::StoreU(moved_to_z, d, a.z + i);
  store_records(d, a, i, moved_to_x, moved_to_y, moved_to_z, vx, vy, vz);
  if (a.dx != nullptr) {
    hn::StoreU(hn::LoadU(d, a.dx + i) + step_x, d, a.dx + i);
    hn::StoreU(hn::LoadU(d, a.dy + i) + step_y, d, a.dy + i);
    hn::StoreU(hn::LoadU(d, a.dz + i) + step_z, d, a.dz + i);
  }
  const auto moved_x = moved_to_x - hn::LoadU(d, a.x0 + i);
  const auto moved_y = moved_to_y - hn::LoadU(d, a.y0 + i);
  const auto moved_z = moved_to_z - hn::LoadU(d, a.z0 + i);
  return moved_x * moved_x + moved_y * moved_y + moved_z * moved_z;
}

/// Both half kicks of the spins for the lanes at @p i by the same torques and 1/I, as
/// close_lanes then open_lanes make them. A loop of its own (ClosingOpeningSweep): out of cache,
/// the one loop's 20 arrays (mass, radius, position, velocity, force, spin, torque, build
/// position) were more streams from memory than this core serves at full speed, and the
/// translation's 13 and the spins' 8 in two loops take less time than those 20 in one: 50 steps
/// of the 998 400 lattice, one thread, the sweep's perf samples 730 -> 518, loop 0.88-0.96 of the
/// time (five alternating rounds); the 20 800 lattice even (0.99-1.02), the same bytes.
template <class D>
HWY_INLINE void close_open_spin_lanes(D d, const SweepArrays& a, hn::Vec<D> half_dt,
                                      std::size_t i) {
  const auto r = hn::LoadU(d, a.radius + i);
  const auto inertia = hn::Set(d, 0.4) * hn::LoadU(d, a.mass + i) * r * r;
  const auto spin_kick = half_dt * (hn::Set(d, 1.0) / inertia);
  const auto tx = hn::LoadU(d, a.tx + i), ty = hn::LoadU(d, a.ty + i), tz = hn::LoadU(d, a.tz + i);
  const auto wx = (hn::LoadU(d, a.wx + i) + spin_kick * tx) + spin_kick * tx;
  const auto wy = (hn::LoadU(d, a.wy + i) + spin_kick * ty) + spin_kick * ty;
  const auto wz = (hn::LoadU(d, a.wz + i) + spin_kick * tz) + spin_kick * tz;
  hn::StoreU(wx, d, a.wx + i);
  hn::StoreU(wy, d, a.wy + i);
  hn::StoreU(wz, d, a.wz + i);
  store_spin_records(d, a, i, wx, wy, wz);
}

SweepResult ClosingOpeningSweep(const SweepArrays& a, double dt, std::size_t first,
                                std::size_t end) {
  const hn::ScalableTag<double> d;
  const hn::CappedTag<double, 1> d1;
  if (a.wx != nullptr) {
    std::size_t i = first;
    for (; i + hn::Lanes(d) <= end; i += hn::Lanes(d)) {
      close_open_spin_lanes(d, a, hn::Set(d, 0.5 * dt), i);
    }
    for (; i < end; ++i) close_open_spin_lanes(d1, a, hn::Set(d1, 0.5 * dt), i);
  }
  auto largest = hn::Zero(d);
  auto largest_1 = hn::Zero(d1);
  bool finite = true;
  std::size_t i = first;
  for (; i + hn::Lanes(d) <= end; i += hn::Lanes(d)) {
    hn::Mask<decltype(d)> lanes_finite;
    const auto moved_sq =
        close_open_lanes(d, a, hn::Set(d, dt), hn::Set(d, 0.5 * dt), i, lanes_finite);
    largest = keep_largest(d, a, largest, moved_sq, i);
    finite = hn::AllTrue(d, lanes_finite) && finite;
  }
  for (; i < end; ++i) {
    hn::Mask<decltype(d1)> lane_finite;
    const auto moved_sq =
        close_open_lanes(d1, a, hn::Set(d1, dt), hn::Set(d1, 0.5 * dt), i, lane_finite);
    largest_1 = keep_largest(d1, a, largest_1, moved_sq, i);
    finite = hn::AllTrue(d1, lane_finite) && finite;
  }
  return {std::max(largest_lane(d, largest), largest_lane(d1, largest_1)), finite};
}

bool ClosingSweep(const SweepArrays& a, double dt, std::size_t first, std::size_t end) {
  const hn::ScalableTag<double> d;
  const hn::CappedTag<double, 1> d1;
  bool finite = true;
  std::size_t i = first;
  for (; i + hn::Lanes(d) <= end; i += hn::Lanes(d)) {
    finite = hn::AllTrue(d, close_lanes(d, a, hn::Set(d, 0.5 * dt), i)) && finite;
  }
  for (; i < end; ++i)
    finite = hn::AllTrue(d1, close_lanes(d1, a, hn::Set(d1, 0.5 * dt), i)) && finite;
  return finite;
}

}  // namespace bondem::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace bondem {

HWY_EXPORT(OpeningSweep);
HWY_EXPORT(ClosingSweep);
HWY_EXPORT(ClosingOpeningSweep);

double opening_sweep(const SweepArrays& a, double dt, std::size_t first, std::size_t end) {
  return HWY_DYNAMIC_DISPATCH(OpeningSweep)(a, dt, first, end);
}

bool closing_sweep(const SweepArrays& a, double dt, std::size_t first, std::size_t end) {
  return HWY_DYNAMIC_DISPATCH(ClosingSweep)(a, dt, first, end);
}

SweepResult closing_opening_sweep(const SweepArrays& a, double dt, std::size_t first,
                                  std::size_t end) {
  return HWY_DYNAMIC_DISPATCH(ClosingOpeningSweep)(a, dt, first, end);
}

}  // namespace bondem
#endif  // HWY_ONCE
