// Per-target header (Highway's -inl.h convention): included once per SIMD target by
// solver/engine/pair_kernel_simd.cpp through hwy/foreach_target.h, hence no #pragma once.
/// @file contact_lanes-inl.h
/// The damped Hertz contact and bond (bond_law.hpp, eq. 15, 22-26, alpha_adh = 1), the
/// Mindlin-Coulomb tangential spring (tangential_law.hpp) and the constant directional rolling
/// torque (rolling_law.hpp, Ai et al. model A) over SIMD lanes, one contact per lane.
///
/// Same laws as the scalar headers, written with fewer roots and divisions: with the contact
/// radius a = sqrt(r* delta),
///   Hertz elastic force   k_h delta^1.5 = (4/3) E* a delta     (k_h = (4/3) E* sqrt(r*))
///   Hertz tangent k_con   1.5 k_h sqrt(delta) = 2 E* a
///   adhesion k_adh delta  = k_h sqrt(delta_eq) delta = (4/3) E* sqrt(r* delta_eq) delta
///   bond tangent k*       = k_con - k_adh                      (eq. 24 with alpha = 1)
///   tangential damping    2 xi sqrt(m* 8 G* a) = 2 xi sqrt(m* k_con) sqrt(4 G* / E*)
/// so a frictional contact takes three roots (distance, a, sqrt(m* k_con)) and one division
/// (1/distance, r* and m* from one reciprocal), plus one root and division where a stored spring
/// is turned into the tangent plane and one of each where the contact slides.
///
/// Bit-exact across targets: every lane performs the same IEEE operations in the same order
/// (the build passes -ffp-contract=off, so no target fuses a multiply-add), branches are masks
/// chosen by explicit comparisons (never Min/Max, whose signed-zero results differ by target).
/// Pure functions: no I/O, no allocation, no state.

#if defined(BONDEM_CONTACT_LANES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef BONDEM_CONTACT_LANES_INL_H_
#undef BONDEM_CONTACT_LANES_INL_H_
#else
#define BONDEM_CONTACT_LANES_INL_H_
#endif

#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace bondem::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// @p value where @p clear is false, else +0.
template <class D>
HWY_INLINE hn::Vec<D> zero_where(D /*d*/, hn::Mask<D> clear, hn::Vec<D> value) {
  return hn::IfThenZeroElse(clear, value);
}

/// The normal part of the damped Hertz contact (eq. 26) on each lane.
template <class D>
struct HertzLanes {
  hn::Vec<D> force;      ///< f . n_ij on i, <= 0 (a contact never attracts) [N]
  hn::Vec<D> elastic;    ///< k_h delta^1.5, the load that limits a bond's friction [N]
  hn::Vec<D> root_mk;    ///< sqrt(m* k_con), shared by the normal and tangential dampers
  hn::Vec<D> stiffness;  ///< k_con = 2 E* a [N/m]
};

/// sqrt(m* k_con) with k_con = 2 E* a: the root of the Hertz damper, separate from hertz_lanes so
/// that a kernel can take every root of a block in one short loop.
template <class D>
HWY_INLINE hn::Vec<D> hertz_root_mk(D /*d*/, hn::Vec<D> two_e, hn::Vec<D> m_star, hn::Vec<D> a) {
  return hn::Sqrt(m_star * (two_e * a));
}

/// Damped Hertz contact at @p overlap (> 0 on the lanes that matter) approaching at @p rate, with
/// contact radius @p a = sqrt(r* delta), @p root_mk = hertz_root_mk(2 E*, m*, a) and pair
/// constants (4/3) E*, 2 E* and 2 xi_con.
template <class D>
HWY_INLINE HertzLanes<D> hertz_lanes(D d, hn::Vec<D> four_thirds_e, hn::Vec<D> two_e,
                                     hn::Vec<D> two_xi, hn::Vec<D> root_mk, hn::Vec<D> a,
                                     hn::Vec<D> overlap, hn::Vec<D> rate) {
  HertzLanes<D> h;
  h.elastic = four_thirds_e * a * overlap;
  h.stiffness = two_e * a;
  h.root_mk = root_mk;
  const hn::Vec<D> force = hn::Neg(h.elastic) - two_xi * h.root_mk * rate;
  h.force = zero_where(d, force > hn::Zero(d), force);
  return h;
}

/// Bond force (eq. 15, 22-24, alpha_adh = 1) with both sign rules of Sec. 4, given the Hertz
/// lanes @p h of the same overlap, the adhesion stiffness @p k_adh, delta_eq and 2 xi_bond.
template <class D>
HWY_INLINE hn::Vec<D> bond_lanes(D d, const HertzLanes<D>& h, hn::Vec<D> k_adh,
                                 hn::Vec<D> equilibrium_overlap, hn::Vec<D> two_xi_bond,
                                 hn::Vec<D> m_star, hn::Vec<D> overlap, hn::Vec<D> rate) {
  const hn::Vec<D> zero = hn::Zero(d);
  const hn::Vec<D> elastic = k_adh * overlap - h.elastic;
  const hn::Vec<D> tangent = h.stiffness - k_adh;
  // k* is zero at delta_crit by construction; clamp round-off so the root stays real.
  const hn::Vec<D> damping =
      two_xi_bond * hn::Sqrt(m_star * zero_where(d, tangent < zero, tangent));
  const hn::Vec<D> force = elastic - damping * rate;
  const hn::Mask<D> compressed = overlap > equilibrium_overlap;
  const hn::Mask<D> wrong_sign =
      hn::Or(hn::And(compressed, force > zero), hn::AndNot(compressed, force < zero));
  return zero_where(d, wrong_sign, force);
}

/// A 3-vector per lane.
template <class D>
struct Lanes3 {
  hn::Vec<D> x, y, z;
};

template <class D>
HWY_INLINE hn::Vec<D> dot(const Lanes3<D>& a, const Lanes3<D>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

template <class D>
HWY_INLINE Lanes3<D> cross(const Lanes3<D>& a, const Lanes3<D>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

/// @p v minus its component along the unit @p n.
template <class D>
HWY_INLINE Lanes3<D> tangential_part(const Lanes3<D>& v, const Lanes3<D>& n) {
  const hn::Vec<D> along = dot(v, n);
  return {v.x - along * n.x, v.y - along * n.y, v.z - along * n.z};
}

/// Cundall-Strack spring (tangential_force of tangential_law.hpp) on each lane: @p spring is
/// turned into the tangent plane of @p n keeping its length, advanced by @p sliding dt, and the
/// trial force k_t s + d_t v_t is capped at mu * load, the spring then carrying the cap. Updates
/// @p spring; returns the force on i. Lanes outside @p active may hold anything.
template <class D>
HWY_INLINE Lanes3<D> tangential_lanes(D d, hn::Mask<D> active, hn::Vec<D> k_t, hn::Vec<D> d_t,
                                      hn::Vec<D> limit, const Lanes3<D>& n,
                                      const Lanes3<D>& sliding, hn::Vec<D> dt, Lanes3<D>& spring) {
  const hn::Vec<D> zero = hn::Zero(d);
  Lanes3<D> s = tangential_part(spring, n);
  const hn::Vec<D> before_sq = dot(spring, spring);
  const hn::Vec<D> after_sq = dot(s, s);
  // Rescale only where the turn changed the length: a fresh (zero) spring or one already in the
  // plane needs neither the root nor the division, and a block without such lanes skips both.
  const hn::Mask<D> turned = hn::And(active, hn::And(after_sq > zero, after_sq != before_sq));
  if (!hn::AllFalse(d, turned)) {
    const hn::Vec<D> scale = hn::IfThenElse(
        turned, hn::Sqrt(before_sq / hn::IfThenElse(turned, after_sq, before_sq)), hn::Set(d, 1.0));
    s = {s.x * scale, s.y * scale, s.z * scale};
  }
  s = {s.x + sliding.x * dt, s.y + sliding.y * dt, s.z + sliding.z * dt};
  Lanes3<D> force{k_t * s.x + d_t * sliding.x, k_t * s.y + d_t * sliding.y,
                  k_t * s.z + d_t * sliding.z};
  const hn::Vec<D> magnitude_sq = dot(force, force);
  const hn::Mask<D> sliding_now = hn::And(active, magnitude_sq > limit * limit);
  if (!hn::AllFalse(d, sliding_now)) {
    // One reciprocal for both the cap limit/|F| and the spring F_capped / k_t.
    const hn::Vec<D> one = hn::Set(d, 1.0);
    const hn::Vec<D> magnitude = hn::Sqrt(hn::IfThenElse(sliding_now, magnitude_sq, one));
    const hn::Vec<D> kt = hn::IfThenElse(sliding_now, k_t, one);
    const hn::Vec<D> q = one / (magnitude * kt);
    const hn::Vec<D> force_scale = hn::IfThenElse(sliding_now, limit * kt * q, one);
    const hn::Vec<D> spring_scale = limit * q;
    const Lanes3<D> capped{force.x * force_scale, force.y * force_scale, force.z * force_scale};
    s = {hn::IfThenElse(sliding_now, force.x * spring_scale, s.x),
         hn::IfThenElse(sliding_now, force.y * spring_scale, s.y),
         hn::IfThenElse(sliding_now, force.z * spring_scale, s.z)};
    force = capped;
  }
  spring = s;
  return force;
}

/// Constant directional rolling torque on i (rolling_torque of rolling_law.hpp, Ai et al. 2011
/// model type A) on each lane: -mu_r r* load along the relative spin @p relative_spin
/// (omega_i - omega_j), capped at I* |omega_rel| / dt so that one step cannot reverse it. The
/// pair's inertia I* = I_i I_j / (I_i + I_j) comes from @p inertia_i, @p inertia_j. Zero where
/// the lane is outside @p active, mu_r = 0 or the spins agree.
template <class D>
HWY_INLINE Lanes3<D> rolling_lanes(D d, hn::Mask<D> active, hn::Vec<D> rolling_friction,
                                   hn::Vec<D> r_star, hn::Vec<D> load, hn::Vec<D> inertia_i,
                                   hn::Vec<D> inertia_j, const Lanes3<D>& relative_spin,
                                   hn::Vec<D> dt) {
  const hn::Vec<D> zero = hn::Zero(d);
  const hn::Vec<D> spin_sq = dot(relative_spin, relative_spin);
  const hn::Mask<D> rolls = hn::And(active, hn::And(rolling_friction != zero, spin_sq > zero));
  if (hn::AllFalse(d, rolls)) return {zero, zero, zero};
  const hn::Vec<D> one = hn::Set(d, 1.0);
  const hn::Vec<D> spin = hn::Sqrt(hn::IfThenElse(rolls, spin_sq, one));
  const hn::Vec<D> inertia_sum = hn::IfThenElse(rolls, inertia_i + inertia_j, one);
  const hn::Vec<D> inertia = inertia_i * inertia_j / inertia_sum;
  const hn::Vec<D> resistance = rolling_friction * r_star * load;
  const hn::Vec<D> spin_limit = inertia * spin / dt;
  const hn::Vec<D> magnitude = hn::IfThenElse(spin_limit < resistance, spin_limit, resistance);
  const hn::Vec<D> scale = hn::Neg(magnitude / spin);
  // +0 where the pair does not roll, as rolling_torque's Zero(): a spin component times +0
  // would be -0 where negative, and a vector that mixes rolling and idle lanes would store
  // other bytes than the lanes of a narrower target.
  return {hn::IfThenElseZero(rolls, relative_spin.x * scale),
          hn::IfThenElseZero(rolls, relative_spin.y * scale),
          hn::IfThenElseZero(rolls, relative_spin.z * scale)};
}

}  // namespace bondem::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // BONDEM_CONTACT_LANES_INL_H_
