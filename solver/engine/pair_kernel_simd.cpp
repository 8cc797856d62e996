// Pass 1 in SIMD lanes (pair_kernel_simd.hpp). Highway re-includes this file once per target
// (hwy/foreach_target.h): the code between HWY_BEFORE_NAMESPACE and HWY_AFTER_NAMESPACE is
// compiled for each instruction set, the HWY_ONCE part once.
#include "solver/engine/pair_kernel_simd.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "solver/engine/pair_kernel_simd.cpp"
#include <hwy/cache_control.h>
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>
#include <omp.h>

#include "solver/models/contact_lanes-inl.h"

#ifndef BONDEM_PAIR_KERNEL_SIMD_ONCE
#define BONDEM_PAIR_KERNEL_SIMD_ONCE
namespace bondem::detail {
/// What every target's pass reads and writes.
struct LanePassArgs {
  const Particles* particles;
  const Scene* scene;
  const NeighborList* list;
  const LanePairConstants* constants;  ///< per material pair, pair_table order
  const BondingCriterion* criterion;
  PairForces* out;
  PairHistory* history;
  bool uniform;  ///< one material pair: constants[0] for every lane
  bool rolling;  ///< some material pair has rolling resistance: pairs store a rolling torque
  /// Every pair's bonding criterion, when the same for all: 0 never, 1 always; -1: per pair.
  int uniform_criterion;
  const double* shift_x;  ///< periodic shifts by image code (NeighborList::shift_table)
  const double* shift_y;
  const double* shift_z;
  /// Per particle, 1 where the pairs in its row are counted in the summary; null: all are.
  const std::uint8_t* counted;
  /// Whether each block prefetches the next block's j particles (kPrefetchParticles).
  bool prefetch;
  /// (x, y, z, r) of every particle and then (vx, vy, vz, m) of every particle, four doubles
  /// each (FillKinematics), or null: the block gather then reads the particle arrays.
  const double* kinematics;
  /// (wx, wy, wz, 0) of every particle after those (records_hold_spins), or null: the block
  /// gather reads the spin arrays.
  const double* spins;
  /// Whether the lanes write the force slots (F, n x F_t, delta) with non-temporal stores
  /// (set_stream_pair_slots_from).
  bool stream_slots;
  /// Where pair k's force slots lie: slots[v] + (k - slot_shift), v in the order fx, fy, fz, cx,
  /// cy, cz, overlap. The arrays of @c out (shift 0), or a ring of the fused pass
  /// (simd_pair_forces_fused).
  double* slots[7];
  std::uint32_t slot_shift;
  /// Where pair k's record lies, if the pass writes records (PairForces::records, or a ring of
  /// them): records + 8 (k - slot_shift); null: the slots.
  double* records;
  /// Where the pairs read after the fused pass's ring has moved on are copied to; null: none.
  const KeptPairs* kept;
};
}  // namespace bondem::detail
#endif

HWY_BEFORE_NAMESPACE();
namespace bondem::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// Pairs gathered per block: enough lanes to hide the latency of the roots and divisions, little
/// enough to keep the block's inputs in L1.
constexpr std::uint32_t kLaneBlock = 64;

/// A block of pairs in lane order: their particles, the kinematics the laws read and, where they
/// are not the same for every pair, the bonding criterion and the material pair's constants.
/// Lanes past the block's last pair hold a pair far apart (pad_block) and are masked out.
struct PairBlock {
  static constexpr int kConstants = 12;
  // The pair's kinematics, gathered by scalar loads or transposed from the records (both cheaper
  // than vector gathers here).
  /// i, with room for a vector store past the block (broadcast_row fills it by rows); j is read
  /// from the list in place.
  std::uint32_t first[kLaneBlock + HWY_MAX_BYTES / sizeof(std::uint32_t)];
  HWY_ALIGN double dx[kLaneBlock], dy[kLaneBlock], dz[kLaneBlock];  ///< x_j - x_i (image of j)
  /// i's radius, mass and spin, a vector of copies per row (broadcast_row): room past the block.
  static constexpr std::uint32_t kRowSlots = kLaneBlock + HWY_MAX_BYTES / sizeof(double);
  HWY_ALIGN double ri[kRowSlots], mi[kRowSlots];
  HWY_ALIGN double wix[kRowSlots], wiy[kRowSlots], wiz[kRowSlots];
  HWY_ALIGN double rj[kLaneBlock], mj[kLaneBlock];
  HWY_ALIGN double dvx[kLaneBlock], dvy[kLaneBlock], dvz[kLaneBlock];  ///< v_j - v_i
  HWY_ALIGN double wjx[kLaneBlock], wjy[kLaneBlock], wjz[kLaneBlock];
  // What the geometry loop of evaluate_block measures for the law loop.
  HWY_ALIGN double nx[kLaneBlock], ny[kLaneBlock], nz[kLaneBlock];  ///< unit n, i toward j
  HWY_ALIGN double overlap[kLaneBlock];  ///< delta where in contact, else +0
  HWY_ALIGN double r_star[kLaneBlock], m_star[kLaneBlock];
  HWY_ALIGN double a_contact[kLaneBlock];  ///< contact radius sqrt(r* delta)
  HWY_ALIGN double root_mk[kLaneBlock];    ///< sqrt(m* k_con), hertz_root_mk
  HWY_ALIGN double criterion[kLaneBlock];  ///< 1 where the pair may bond now
  HWY_ALIGN double bonded[kLaneBlock];     ///< out: 1 where the pair is bonded after the pass
  /// Per-lane LanePairConstants, filled only when the scene has several material pairs.
  HWY_ALIGN double constant[kConstants][kLaneBlock];
};

/// The members of LanePairConstants in PairBlock::constant order.
inline void put_constants(PairBlock& b, std::uint32_t s, const LanePairConstants& c) {
  const double values[PairBlock::kConstants] = {c.four_thirds_e,
                                                c.two_e,
                                                c.two_xi_contact,
                                                c.two_xi_bond,
                                                c.equilibrium_overlap,
                                                c.adhesion_stiffness,
                                                c.stiffness_input,
                                                c.critical_ratio,
                                                c.eight_g,
                                                c.tangential_ratio,
                                                c.friction,
                                                c.rolling_friction};
  for (int v = 0; v < PairBlock::kConstants; ++v) b.constant[v][s] = values[v];
}

/// Writes particle @p i's index, radius, mass and (kFriction) spin into lanes [@p begin, @p end)
/// of @p b, the pairs of its row: a vector of copies at a time, the last one running past @p end
/// into what the next row then overwrites. A row usually fits one vector, so its pairs cost one
/// store per value instead of one per pair, and no branch per pair on where the row ends.
template <bool kFriction>
HWY_INLINE void broadcast_row(const Particles& p, PairBlock& b, std::uint32_t i,
                              std::uint32_t begin, std::uint32_t end) {
  const hn::ScalableTag<std::uint32_t> du;
  const auto index = hn::Set(du, i);
  for (std::uint32_t t = begin; t < end; t += static_cast<std::uint32_t>(hn::Lanes(du))) {
    hn::StoreU(index, du, b.first + t);
  }
  // Four lanes at a time: most rows are short, and a narrower store crosses fewer cache lines.
  const hn::CappedTag<double, 4> d;
  const auto radius = hn::Set(d, p.radius[i]);
  const auto mass = hn::Set(d, p.mass[i]);
  for (std::uint32_t t = begin; t < end; t += static_cast<std::uint32_t>(hn::Lanes(d))) {
    hn::StoreU(radius, d, b.ri + t);
    hn::StoreU(mass, d, b.mi + t);
  }
  if constexpr (kFriction) {
    const auto wx = hn::Set(d, p.wx[i]), wy = hn::Set(d, p.wy[i]), wz = hn::Set(d, p.wz[i]);
    for (std::uint32_t t = begin; t < end; t += static_cast<std::uint32_t>(hn::Lanes(d))) {
      hn::StoreU(wx, d, b.wix + t);
      hn::StoreU(wy, d, b.wiy + t);
      hn::StoreU(wz, d, b.wiz + t);
    }
  }
}

#if HWY_TARGET != HWY_SCALAR
/// The quadruples at @p records + 4 @p index[l], one per lane l, as four vectors of their first,
/// second, third and fourth values, transposed in registers. Two or more lanes: pairs of lanes
/// interleaved by 128-bit blocks, then the blocks regrouped in lane order.
template <class D>
HWY_INLINE void load_transposed(D d, const double* HWY_RESTRICT records,
                                const std::uint32_t* HWY_RESTRICT index, hn::Vec<D>& first,
                                hn::Vec<D>& second, hn::Vec<D>& third, hn::Vec<D>& fourth) {
  const auto at = [&](std::size_t l) { return records + 4 * std::size_t{index[l]}; };
  if constexpr (hn::MaxLanes(d) == 2) {
    const hn::Vec<D> front0 = hn::LoadU(d, at(0)), back0 = hn::LoadU(d, at(0) + 2);
    const hn::Vec<D> front1 = hn::LoadU(d, at(1)), back1 = hn::LoadU(d, at(1) + 2);
    first = hn::InterleaveLower(d, front0, front1);
    second = hn::InterleaveUpper(d, front0, front1);
    third = hn::InterleaveLower(d, back0, back1);
    fourth = hn::InterleaveUpper(d, back0, back1);
  } else if constexpr (hn::MaxLanes(d) == 4) {
    const hn::Vec<D> r0 = hn::LoadU(d, at(0)), r1 = hn::LoadU(d, at(1));
    const hn::Vec<D> r2 = hn::LoadU(d, at(2)), r3 = hn::LoadU(d, at(3));
    const hn::Vec<D> low01 = hn::InterleaveLower(d, r0, r1);   // (a0 a1)(c0 c1)
    const hn::Vec<D> high01 = hn::InterleaveUpper(d, r0, r1);  // (b0 b1)(d0 d1)
    const hn::Vec<D> low23 = hn::InterleaveLower(d, r2, r3);
    const hn::Vec<D> high23 = hn::InterleaveUpper(d, r2, r3);
    first = hn::ConcatLowerLower(d, low23, low01);
    third = hn::ConcatUpperUpper(d, low23, low01);
    second = hn::ConcatLowerLower(d, high23, high01);
    fourth = hn::ConcatUpperUpper(d, high23, high01);
  } else {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
    static_assert(hn::MaxLanes(d) == 8);
    const auto two = [&](std::size_t low, std::size_t high) HWY_ATTR {
      return _mm512_insertf64x4(_mm512_castpd256_pd512(_mm256_loadu_pd(at(low))),
                                _mm256_loadu_pd(at(high)), 1);
    };
    // Records 0 and 2 in one vector, 1 and 3 in the next: their interleaves hold lanes (0, 1)
    // and (2, 3) in the blocks that the regrouping then takes in order.
    const __m512d r02 = two(0, 2), r13 = two(1, 3), r46 = two(4, 6), r57 = two(5, 7);
    const __m512d low_0123 = _mm512_unpacklo_pd(r02, r13);   // (a0 a1)(c0 c1)(a2 a3)(c2 c3)
    const __m512d high_0123 = _mm512_unpackhi_pd(r02, r13);  // (b0 b1)(d0 d1)(b2 b3)(d2 d3)
    const __m512d low_4567 = _mm512_unpacklo_pd(r46, r57);
    const __m512d high_4567 = _mm512_unpackhi_pd(r46, r57);
    first.raw = _mm512_shuffle_f64x2(low_0123, low_4567, _MM_SHUFFLE(2, 0, 2, 0));
    third.raw = _mm512_shuffle_f64x2(low_0123, low_4567, _MM_SHUFFLE(3, 1, 3, 1));
    second.raw = _mm512_shuffle_f64x2(high_0123, high_4567, _MM_SHUFFLE(2, 0, 2, 0));
    fourth.raw = _mm512_shuffle_f64x2(high_0123, high_4567, _MM_SHUFFLE(3, 1, 3, 1));
#else
    static_assert(hn::MaxLanes(d) == 0, "load_transposed: no transposition for these lanes");
#endif
  }
}

/// Whether load_transposed serves the lanes of @p d: two, four, or eight on x86.
template <class D>
constexpr bool kTransposes = hn::MaxLanes(D()) == 2 || hn::MaxLanes(D()) == 4 ||
                             (HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3 && hn::MaxLanes(D()) == 8);
#endif  // HWY_TARGET != HWY_SCALAR

/// The block's differences x_j - x_i + 0 (before shifts) and v_j - v_i, r_j and m_j, and where
/// LanePassArgs::spins is set j's spin, from the kinematics records: transposed into lanes in
/// registers (load_transposed) on every target with two or more lanes; with one, each pair's two
/// records copied into four arrays of quadruples, which LoadInterleaved4 takes into lanes. Lanes
/// past @p count repeat the last pair (or take zeros), and pad_block overwrites what they give.
template <bool kFriction>
HWY_INLINE void pack_kinematics(const detail::LanePassArgs& a, PairBlock& b, std::uint32_t first_k,
                                std::uint32_t count) {
  const std::uint32_t* HWY_RESTRICT first = b.first;
  const std::uint32_t* HWY_RESTRICT second = a.list->seconds() + first_k;
  const double* HWY_RESTRICT positions = a.kinematics;
  const double* HWY_RESTRICT velocities = a.kinematics + 4 * a.particles->size();
  [[maybe_unused]] const double* HWY_RESTRICT spins = a.spins;
#if HWY_TARGET != HWY_SCALAR  // one lane: the copy below is the transposition
  using D = hn::ScalableTag<double>;
  if constexpr (kTransposes<D>) {
    // A vector of pairs at a time, transposed in registers: copied through memory (the path
    // below), each record went in as quarter- or half-vector stores and came back in whole
    // vectors, likely loads the store buffer cannot forward; the 20 800 peer lattice 0.92 of the
    // time on AVX-512 and AVX2. The same values: x_j - x_i + 0 as below.
    const D d;
    constexpr std::uint32_t kLanes = static_cast<std::uint32_t>(hn::MaxLanes(d));
    const auto zero = hn::Zero(d);
    for (std::uint32_t s = 0; s < count; s += kLanes) {
      const std::uint32_t* HWY_RESTRICT is = first + s;
      const std::uint32_t* HWY_RESTRICT js = second + s;
      std::uint32_t tail_i[kLanes], tail_j[kLanes];
      if (s + kLanes > count) {
        // The last lanes repeat the block's last pair, so that every index read is a pair's.
        for (std::uint32_t l = 0; l < kLanes; ++l) {
          tail_i[l] = first[std::min(s + l, count - 1)];
          tail_j[l] = second[std::min(s + l, count - 1)];
        }
        is = tail_i;
        js = tail_j;
      }
      hn::Vec<D> xi, yi, zi, unused, xj, yj, zj, rj;
      load_transposed(d, positions, is, xi, yi, zi, unused);
      load_transposed(d, positions, js, xj, yj, zj, rj);
      hn::Store(hn::Add(hn::Sub(xj, xi), zero), d, b.dx + s);
      hn::Store(hn::Add(hn::Sub(yj, yi), zero), d, b.dy + s);
      hn::Store(hn::Add(hn::Sub(zj, zi), zero), d, b.dz + s);
      hn::Store(rj, d, b.rj + s);
      hn::Vec<D> vxi, vyi, vzi, vxj, vyj, vzj, mj;
      load_transposed(d, velocities, is, vxi, vyi, vzi, unused);
      load_transposed(d, velocities, js, vxj, vyj, vzj, mj);
      hn::Store(hn::Sub(vxj, vxi), d, b.dvx + s);
      hn::Store(hn::Sub(vyj, vyi), d, b.dvy + s);
      hn::Store(hn::Sub(vzj, vzi), d, b.dvz + s);
      hn::Store(mj, d, b.mj + s);
      if (kFriction && spins != nullptr) {
        hn::Vec<D> wxj, wyj, wzj;
        load_transposed(d, spins, js, wxj, wyj, wzj, unused);
        hn::Store(wxj, d, b.wjx + s);
        hn::Store(wyj, d, b.wjy + s);
        hn::Store(wzj, d, b.wjz + s);
      }
    }
    return;
  }
#endif
  HWY_ALIGN double position_i[4 * kLaneBlock], position_j[4 * kLaneBlock];
  HWY_ALIGN double velocity_i[4 * kLaneBlock], velocity_j[4 * kLaneBlock];
  for (std::uint32_t s = 0; s < count; ++s) {
    std::memcpy(position_i + 4 * s, positions + 4 * first[s], 4 * sizeof(double));
    std::memcpy(velocity_i + 4 * s, velocities + 4 * first[s], 4 * sizeof(double));
    std::memcpy(position_j + 4 * s, positions + 4 * second[s], 4 * sizeof(double));
    std::memcpy(velocity_j + 4 * s, velocities + 4 * second[s], 4 * sizeof(double));
  }
  const hn::ScalableTag<double> d;
  const std::size_t lanes = hn::Lanes(d);
  const auto zero = hn::Zero(d);
  const std::size_t padded = (count + lanes - 1) / lanes * lanes;
  for (double* quadruples : {position_i, position_j, velocity_i, velocity_j}) {
    std::fill(quadruples + 4 * count, quadruples + 4 * padded, 0.0);
  }
  for (std::uint32_t s = 0; s < count; s += static_cast<std::uint32_t>(lanes)) {
    hn::Vec<decltype(d)> xi, yi, zi, ri, xj, yj, zj, rj;
    hn::LoadInterleaved4(d, position_i + 4 * s, xi, yi, zi, ri);
    hn::LoadInterleaved4(d, position_j + 4 * s, xj, yj, zj, rj);
    // As the scalar gather: (x_j - x_i) + 0, which turns -0 into +0.
    hn::Store(hn::Add(hn::Sub(xj, xi), zero), d, b.dx + s);
    hn::Store(hn::Add(hn::Sub(yj, yi), zero), d, b.dy + s);
    hn::Store(hn::Add(hn::Sub(zj, zi), zero), d, b.dz + s);
    hn::Store(rj, d, b.rj + s);
    hn::Vec<decltype(d)> vxi, vyi, vzi, mi, vxj, vyj, vzj, mj;
    hn::LoadInterleaved4(d, velocity_i + 4 * s, vxi, vyi, vzi, mi);
    hn::LoadInterleaved4(d, velocity_j + 4 * s, vxj, vyj, vzj, mj);
    hn::Store(hn::Sub(vxj, vxi), d, b.dvx + s);
    hn::Store(hn::Sub(vyj, vyi), d, b.dvy + s);
    hn::Store(hn::Sub(vzj, vzi), d, b.dvz + s);
    hn::Store(mj, d, b.mj + s);
  }
}

/// Gathers j's kinematics and the pair's differences for the block's @p count pairs, i =
/// b.first[s] (broadcast_row) and j the list's second particle of pair first_k + s, into lane
/// order: a few short loops, each with few streams, keep the pointers in registers. With
/// @p next (the next block's j, at least @p count of them; null: no prefetching), each loop that
/// reads the particle arrays also prefetches them at next[s]: spread over the gather, the
/// prefetches of the next block wait for the memory one at a time instead of stalling the pass in a
/// burst of up to 11 x 64 before it. What it gives depends on the host's hour: bench_step, one
/// thread, paired steps against the burst 0.980-0.995 at 997 477 spheres, 0.99-1.00 at 130 000;
/// 50-step runs of the 998 400 lattice against the burst's build, median 0.97 in a slow hour and
/// 1.02 in a fast one (8 alternating rounds, 0.95-1.10).
template <bool kFriction>
HWY_NOINLINE void pack_block(const detail::LanePassArgs& a, PairBlock& b, std::uint32_t first_k,
                             std::uint32_t count, const std::uint32_t* next) {
  const Particles& p = *a.particles;
  const std::uint32_t* HWY_RESTRICT first = b.first;
  const std::uint32_t* HWY_RESTRICT second = a.list->seconds() + first_k;
  // The same for every pair of the call: a branch the predictor never misses.
  const bool prefetch_next = next != nullptr;
  if (a.kinematics != nullptr) {
    pack_kinematics<kFriction>(a, b, first_k, count);
  } else {
    const double* HWY_RESTRICT x = p.x.data();
    const double* HWY_RESTRICT y = p.y.data();
    const double* HWY_RESTRICT z = p.z.data();
    // The scalar pass adds every pair's shift, +0 for most: adding +0 here too turns a
    // difference of -0 into +0 as it does, and (x_j - x_i + 0) + s is (x_j - x_i) + s.
    for (std::uint32_t s = 0; s < count; ++s) {
      if (prefetch_next) {
        __builtin_prefetch(x + next[s]);
        __builtin_prefetch(y + next[s]);
        __builtin_prefetch(z + next[s]);
      }
      b.dx[s] = x[second[s]] - x[first[s]] + 0.0;
      b.dy[s] = y[second[s]] - y[first[s]] + 0.0;
      b.dz[s] = z[second[s]] - z[first[s]] + 0.0;
    }
  }
  {
    // Periodic images are rare: most pairs see j itself and need no other shift.
    const std::uint8_t* HWY_RESTRICT image = a.list->images() + first_k;
    // In locals: a store into the block could otherwise alias the argument's pointers, which
    // would be read again for every pair.
    const double* HWY_RESTRICT shift_x = a.shift_x;
    const double* HWY_RESTRICT shift_y = a.shift_y;
    const double* HWY_RESTRICT shift_z = a.shift_z;
    // Eight codes at a time: a group of unshifted pairs costs one comparison.
    constexpr std::uint64_t kUnshiftedGroup = 0x0101010101010101ull * kUnshiftedImage;
    for (std::uint32_t group = 0; group < count; group += 8) {
      const std::uint32_t group_end = std::min(group + 8, count);
      if (group_end == group + 8) {
        std::uint64_t codes;
        std::memcpy(&codes, image + group, sizeof codes);
        if (codes == kUnshiftedGroup) continue;
      }
      for (std::uint32_t s = group; s < group_end; ++s) {
        const std::uint8_t code = image[s];
        if (code == kUnshiftedImage) continue;
        b.dx[s] += shift_x[code];
        b.dy[s] += shift_y[code];
        b.dz[s] += shift_z[code];
      }
    }
  }
  if (a.kinematics == nullptr) {
    const double* HWY_RESTRICT radius = p.radius.data();
    const double* HWY_RESTRICT mass = p.mass.data();
    for (std::uint32_t s = 0; s < count; ++s) {
      if (prefetch_next) {
        __builtin_prefetch(radius + next[s]);
        __builtin_prefetch(mass + next[s]);
      }
      b.rj[s] = radius[second[s]];
      b.mj[s] = mass[second[s]];
    }
    const double* HWY_RESTRICT vx = p.vx.data();
    const double* HWY_RESTRICT vy = p.vy.data();
    const double* HWY_RESTRICT vz = p.vz.data();
    for (std::uint32_t s = 0; s < count; ++s) {
      if (prefetch_next) {
        __builtin_prefetch(vx + next[s]);
        __builtin_prefetch(vy + next[s]);
        __builtin_prefetch(vz + next[s]);
      }
      b.dvx[s] = vx[second[s]] - vx[first[s]];
      b.dvy[s] = vy[second[s]] - vy[first[s]];
      b.dvz[s] = vz[second[s]] - vz[first[s]];
    }
  }
  // Where the records hold them, pack_kinematics has taken j's spins (but for one lane).
  if (kFriction && (a.spins == nullptr || HWY_TARGET == HWY_SCALAR)) {
    const double* HWY_RESTRICT wx = p.wx.data();
    const double* HWY_RESTRICT wy = p.wy.data();
    const double* HWY_RESTRICT wz = p.wz.data();
    for (std::uint32_t s = 0; s < count; ++s) {
      if (prefetch_next) {  // never with records: LanePass prefetched them
        __builtin_prefetch(wx + next[s]);
        __builtin_prefetch(wy + next[s]);
        __builtin_prefetch(wz + next[s]);
      }
      b.wjx[s] = wx[second[s]];
      b.wjy[s] = wy[second[s]];
      b.wjz[s] = wz[second[s]];
    }
  }
  if (a.uniform_criterion < 0 || !a.uniform) {
    for (std::uint32_t s = 0; s < count; ++s) {
      const std::size_t i = first[s];
      const std::size_t j = second[s];
      const std::size_t pair =
          static_cast<std::size_t>(p.material[i] * a.scene->material_count + p.material[j]);
      if (a.uniform_criterion < 0) {
        b.criterion[s] = (*a.criterion)(a.scene->pair_table[pair], i, j, first_k + s) ? 1.0 : 0.0;
      }
      if (!a.uniform) put_constants(b, s, a.constants[pair]);
    }
  }
}

/// Fills lanes [@p count, @p end) of @p b with a pair far apart (no contact, no NaN).
HWY_INLINE void pad_block(PairBlock& b, std::uint32_t count, std::uint32_t end) {
  for (std::uint32_t s = count; s < end; ++s) {
    b.dx[s] = 1.0;
    b.dy[s] = b.dz[s] = b.ri[s] = b.rj[s] = 0.0;
    b.mi[s] = b.mj[s] = 1.0;
    b.dvx[s] = b.dvy[s] = b.dvz[s] = 0.0;
    b.wix[s] = b.wiy[s] = b.wiz[s] = b.wjx[s] = b.wjy[s] = b.wjz[s] = 0.0;
    b.criterion[s] = 0.0;
    for (int v = 0; v < PairBlock::kConstants; ++v) b.constant[v][s] = 0.0;
  }
}

/// @p valid (<= lanes) values from @p from: a whole vector, or the first lanes and zeros, never
/// reading past @p from + valid.
template <class D>
HWY_INLINE hn::Vec<D> load_lanes(D d, const double* from, std::size_t valid) {
  if (valid >= hn::Lanes(d)) return hn::LoadU(d, from);
  HWY_ALIGN double padded[hn::MaxLanes(d)] = {};
  for (std::size_t l = 0; l < valid; ++l) padded[l] = from[l];
  return hn::Load(d, padded);
}

/// Stores @p v at @p to: the whole vector, or its first @p valid lanes.
template <class D>
HWY_INLINE void store_lanes(D d, hn::Vec<D> v, std::size_t valid, double* to) {
  if (valid >= hn::Lanes(d)) {
    hn::StoreU(v, d, to);
  } else {
    hn::BlendedStore(v, hn::FirstN(d, valid), d, to);
  }
}

/// store_lanes for a force slot, which pass 2 reads and nothing reads before: with @p stream, a
/// whole vector at an aligned @p to bypasses the caches (no read of the line it overwrites);
/// the same values either way.
template <class D>
HWY_INLINE void store_slot(D d, hn::Vec<D> v, std::size_t valid, double* to, bool stream) {
  if (stream && valid >= hn::Lanes(d) &&
      reinterpret_cast<std::uintptr_t>(to) % (hn::Lanes(d) * sizeof(double)) == 0) {
    hn::Stream(v, d, to);
  } else {
    store_lanes(d, v, valid, to);
  }
}

/// Stores the first @p valid lanes as records (fx, fy, fz, delta, cx, cy, cz, 0) at @p to, eight
/// doubles apart: on AVX-512 the 8 x 8 transpose in registers (three rounds of shuffles), a whole
/// 64-B store a pair; elsewhere through a staging block.
template <class D>
HWY_INLINE void store_records(D d, const Lanes3<D>& f, hn::Vec<D> delta, const Lanes3<D>& c,
                              std::size_t valid, double* to) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  if constexpr (hn::MaxLanes(d) == 8) {
    const __m512d r0 = f.x.raw, r1 = f.y.raw, r2 = f.z.raw, r3 = delta.raw;
    const __m512d r4 = c.x.raw, r5 = c.y.raw, r6 = c.z.raw, r7 = _mm512_setzero_pd();
    const __m512d t0 = _mm512_unpacklo_pd(r0, r1), t1 = _mm512_unpackhi_pd(r0, r1);
    const __m512d t2 = _mm512_unpacklo_pd(r2, r3), t3 = _mm512_unpackhi_pd(r2, r3);
    const __m512d t4 = _mm512_unpacklo_pd(r4, r5), t5 = _mm512_unpackhi_pd(r4, r5);
    const __m512d t6 = _mm512_unpacklo_pd(r6, r7), t7 = _mm512_unpackhi_pd(r6, r7);
    const __m512d u0 = _mm512_shuffle_f64x2(t0, t2, 0x88), u1 = _mm512_shuffle_f64x2(t1, t3, 0x88);
    const __m512d u2 = _mm512_shuffle_f64x2(t0, t2, 0xDD), u3 = _mm512_shuffle_f64x2(t1, t3, 0xDD);
    const __m512d u4 = _mm512_shuffle_f64x2(t4, t6, 0x88), u5 = _mm512_shuffle_f64x2(t5, t7, 0x88);
    const __m512d u6 = _mm512_shuffle_f64x2(t4, t6, 0xDD), u7 = _mm512_shuffle_f64x2(t5, t7, 0xDD);
    __m512d rec[8];
    rec[0] = _mm512_shuffle_f64x2(u0, u4, 0x88);
    rec[4] = _mm512_shuffle_f64x2(u0, u4, 0xDD);
    rec[1] = _mm512_shuffle_f64x2(u1, u5, 0x88);
    rec[5] = _mm512_shuffle_f64x2(u1, u5, 0xDD);
    rec[2] = _mm512_shuffle_f64x2(u2, u6, 0x88);
    rec[6] = _mm512_shuffle_f64x2(u2, u6, 0xDD);
    rec[3] = _mm512_shuffle_f64x2(u3, u7, 0x88);
    rec[7] = _mm512_shuffle_f64x2(u3, u7, 0xDD);
    for (std::size_t l = 0; l < valid; ++l) _mm512_storeu_pd(to + 8 * l, rec[l]);
    return;
  }
#endif
  HWY_ALIGN double lanes[8][hn::MaxLanes(d)];
  hn::Store(f.x, d, lanes[0]);
  hn::Store(f.y, d, lanes[1]);
  hn::Store(f.z, d, lanes[2]);
  hn::Store(delta, d, lanes[3]);
  hn::Store(c.x, d, lanes[4]);
  hn::Store(c.y, d, lanes[5]);
  hn::Store(c.z, d, lanes[6]);
  for (std::size_t l = 0; l < valid; ++l) {
    for (int v = 0; v < 7; ++v) to[8 * l + static_cast<std::size_t>(v)] = lanes[v][l];
    to[8 * l + 7] = 0.0;
  }
}

/// gather_record_range on this target: per particle, m g in the force lanes, then each pair of
/// its row (sign +1) and of its column (sign -1) as gather_pairs adds them, sign F in lanes 0-2
/// and (r - delta / 2) (n x F_t) in lanes 4-6 of the record (lanes 3 and 7 are not read back): the
/// same operations per component in the same order, so the same bytes. Against the seven arrays'
/// scalar adds (about 7 cycles a visit), the 20 800 peer lattice 0.90 of the time.
void GatherRecords(Particles& p, const NeighborList& list, const double* HWY_RESTRICT records,
                   double gx, double gy, double gz, std::size_t first, std::size_t end,
                   std::uint32_t mask) {
  const hn::CappedTag<double, 8> d;
  constexpr std::size_t N = hn::MaxLanes(d);
  constexpr std::size_t kVectors = 8 / N;
  using V = hn::Vec<decltype(d)>;
  const double* HWY_RESTRICT mass = p.mass.data();
  const double* HWY_RESTRICT radius = p.radius.data();
  // m g in the force lanes and m 0 = +0 in the others: a vector made in registers (one loaded
  // from scalar stores just made waited for them, 40 % of the loop's samples).
  HWY_ALIGN const double weight_per_mass[8] = {gx, gy, gz, 0.0, 0.0, 0.0, 0.0, 0.0};
  V per_mass[kVectors];
  for (std::size_t c = 0; c < kVectors; ++c) per_mass[c] = hn::Load(d, weight_per_mass + c * N);
  for (std::size_t i = first; i < end; ++i) {
    V acc[kVectors];
    const V m = hn::Set(d, mass[i]);
    for (std::size_t c = 0; c < kVectors; ++c) acc[c] = hn::Mul(m, per_mass[c]);
    const double r = radius[i];
    const auto add = [&](std::uint32_t k, double sign) HWY_ATTR {
      const double* rec = records + 8 * std::size_t{k & mask};
      const double lever = pair_lever(r, rec[3]);
      if constexpr (kVectors == 1) {
        const V factor = hn::IfThenElse(hn::FirstN(d, 4), hn::Set(d, sign), hn::Set(d, lever));
        acc[0] = hn::Add(acc[0], hn::Mul(factor, hn::LoadU(d, rec)));
      } else {
        for (std::size_t c = 0; c < kVectors; ++c) {
          const V factor = hn::Set(d, c * N < 4 ? sign : lever);
          acc[c] = hn::Add(acc[c], hn::Mul(factor, hn::LoadU(d, rec + c * N)));
        }
      }
    };
    list.for_each_pair_of(
        i, [&](std::uint32_t k) HWY_ATTR { add(k, 1.0); },
        [&](std::uint32_t k) HWY_ATTR { add(k, -1.0); });
    HWY_ALIGN double sums[8];
    for (std::size_t c = 0; c < kVectors; ++c) hn::Store(acc[c], d, sums + c * N);
    p.fx[i] = sums[0];
    p.fy[i] = sums[1];
    p.fz[i] = sums[2];
    p.tx[i] = sums[4];
    p.ty[i] = sums[5];
    p.tz[i] = sums[6];
  }
}

/// What the lanes of one pass saw.
struct LaneTally {
  std::size_t contacts = 0, bonds = 0;
  double max_overlap = 0.0, max_fraction = 0.0;
};

/// Evaluates the @p count packed pairs of @p b, stored at pairs first_k ... first_k + count - 1.
template <bool kFriction>
HWY_INLINE void evaluate_block(const detail::LanePassArgs& a, PairBlock& b, std::uint32_t first_k,
                               std::uint32_t count, LaneTally& tally) {
  using D = hn::ScalableTag<double>;
  const D d;
  using V = hn::Vec<D>;
  using M = hn::Mask<D>;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d);
  const V one = hn::Set(d, 1.0);
  const V half = hn::Set(d, 0.5);
  const V dt = hn::Set(d, a.scene->time_step);
  PairForces& out = *a.out;
  PairHistory& history = *a.history;
  // Pair k's record at records + 8 k, slot v at slot(v, k).
  double* const records =
      a.records != nullptr ? a.records - 8 * std::size_t{a.slot_shift} : nullptr;
  const auto slot = [&](int v, std::uint32_t k)
                        HWY_ATTR { return a.slots[v] + (k - a.slot_shift); };
  const LanePairConstants& c0 = a.constants[0];
  const auto constant = [&](int v, double uniform_value, std::uint32_t s) HWY_ATTR {
    return a.uniform ? hn::Set(d, uniform_value) : hn::Load(d, b.constant[v] + s);
  };
  // The geometry first, in a loop of its own: its three roots and one division do not depend on
  // the vector before, so they overlap one another. Inside the law loop each waited at the head
  // of a long chain. Both loops perform the same operations as one would: the same bytes.
  for (std::uint32_t s = 0; s < count; s += static_cast<std::uint32_t>(lanes)) {
    const M in_block = hn::FirstN(d, std::min<std::size_t>(lanes, count - s));
    const V dx = hn::Load(d, b.dx + s), dy = hn::Load(d, b.dy + s), dz = hn::Load(d, b.dz + s);
    const V ri = hn::Load(d, b.ri + s), rj = hn::Load(d, b.rj + s);
    const V distance = hn::Sqrt(dx * dx + dy * dy + dz * dz);
    const V radius_sum = ri + rj;
    const V overlap = radius_sum - distance;
    const M contact = hn::And(in_block, overlap > zero);
    const V mi = hn::Load(d, b.mi + s), mj = hn::Load(d, b.mj + s);
    // One reciprocal gives 1/distance, r* = r_i r_j / (r_i + r_j) and m* likewise.
    const V mass_sum = mi + mj;
    const V q = one / (distance * radius_sum * mass_sum);
    const V inverse_distance = radius_sum * mass_sum * q;
    const V r_star = ri * rj * (distance * mass_sum) * q;
    const V m_star = mi * mj * (distance * radius_sum) * q;
    const V positive_overlap = zero_where(d, hn::Not(contact), overlap);
    const V a_contact = hn::Sqrt(r_star * positive_overlap);
    hn::Store(dx * inverse_distance, d, b.nx + s);
    hn::Store(dy * inverse_distance, d, b.ny + s);
    hn::Store(dz * inverse_distance, d, b.nz + s);
    hn::Store(positive_overlap, d, b.overlap + s);
    hn::Store(r_star, d, b.r_star + s);
    hn::Store(m_star, d, b.m_star + s);
    hn::Store(a_contact, d, b.a_contact + s);
    hn::Store(hertz_root_mk(d, constant(1, c0.two_e, s), m_star, a_contact), d, b.root_mk + s);
  }
  V max_overlap = zero;
  V max_fraction = zero;
  for (std::uint32_t s = 0; s < count; s += static_cast<std::uint32_t>(lanes)) {
    const std::size_t valid = std::min<std::size_t>(lanes, count - s);
    const std::uint32_t k = first_k + s;
    // delta > 0 exactly where the pair is in the block and in contact (the geometry loop).
    const V positive_overlap = hn::Load(d, b.overlap + s);
    const M contact = positive_overlap > zero;
    if (hn::AllFalse(d, contact)) {
      // No contact in these lanes: no force, torque or bond, springs released. The slots as the
      // lanes in contact store theirs, so that a line is not half streamed, half cached.
      if (records != nullptr) {
        std::fill(records + 8 * std::size_t{k}, records + 8 * (std::size_t{k} + valid), 0.0);
      } else {
        for (int v = 0; v < 3; ++v) store_slot(d, zero, valid, slot(v, k), a.stream_slots);
        if constexpr (kFriction) {
          for (int v = 3; v < 7; ++v) store_slot(d, zero, valid, slot(v, k), a.stream_slots);
        }
      }
      hn::Store(zero, d, b.bonded + s);
      if constexpr (kFriction) {
        for (double* to : {history.sx.data(), history.sy.data(), history.sz.data()}) {
          store_lanes(d, zero, valid, to + k);
        }
        if (a.rolling) {
          for (double* to : {out.roll_x.data(), out.roll_y.data(), out.roll_z.data()}) {
            store_lanes(d, zero, valid, to + k);
          }
        }
      }
      continue;
    }
    const V ri = hn::Load(d, b.ri + s), rj = hn::Load(d, b.rj + s);
    const V mi = hn::Load(d, b.mi + s), mj = hn::Load(d, b.mj + s);
    const V r_star = hn::Load(d, b.r_star + s), m_star = hn::Load(d, b.m_star + s);
    const Lanes3<D> n{hn::Load(d, b.nx + s), hn::Load(d, b.ny + s), hn::Load(d, b.nz + s)};
    const Lanes3<D> dv{hn::Load(d, b.dvx + s), hn::Load(d, b.dvy + s), hn::Load(d, b.dvz + s)};
    const V rate = hn::Neg(dot(dv, n));
    const V a_contact = hn::Load(d, b.a_contact + s);
    const V four_thirds_e = constant(0, c0.four_thirds_e, s);
    const HertzLanes<D> h =
        hertz_lanes(d, four_thirds_e, constant(1, c0.two_e, s), constant(2, c0.two_xi_contact, s),
                    hn::Load(d, b.root_mk + s), a_contact, positive_overlap, rate);
    V normal = h.force;
    V load = hn::Neg(h.force);
    M bonded = hn::And(contact, a.uniform_criterion < 0 ? hn::Load(d, b.criterion + s) > zero
                                                        : hn::Set(d, a.uniform_criterion) > zero);
    if (!hn::AllFalse(d, bonded)) {
      // Past delta_crit the bond of eq. 25 replaces the contact; delta_eq is the input, or
      // follows from k_adh by eq. 13: (k_adh / k_h)^2 with k_h^2 = ((4/3) E*)^2 r*.
      const M stiffness_input = constant(6, c0.stiffness_input, s) > zero;
      const V given_k_adh = constant(5, c0.adhesion_stiffness, s);
      const V given_delta_eq = constant(4, c0.equilibrium_overlap, s);
      const V k_h_sq = four_thirds_e * four_thirds_e * r_star;
      const V delta_eq = hn::IfThenElse(
          stiffness_input, given_k_adh * given_k_adh / hn::IfThenElse(stiffness_input, k_h_sq, one),
          given_delta_eq);
      bonded = hn::And(bonded, positive_overlap > constant(7, c0.critical_ratio, s) * delta_eq);
      if (!hn::AllFalse(d, bonded)) {
        const V k_adh = hn::IfThenElse(stiffness_input, given_k_adh,
                                       four_thirds_e * hn::Sqrt(r_star * given_delta_eq));
        const V bond = bond_lanes(d, h, k_adh, delta_eq, constant(3, c0.two_xi_bond, s), m_star,
                                  positive_overlap, rate);
        normal = hn::IfThenElse(bonded, bond, normal);
        // A bond presses with its Hertz part even where the net force vanishes.
        load = hn::IfThenElse(bonded, h.elastic, load);
      }
    }
    hn::Store(hn::IfThenElseZero(bonded, one), d, b.bonded + s);
    Lanes3<D> force{normal * n.x, normal * n.y, normal * n.z};
    Lanes3<D> lever_slot{zero, zero, zero};
    if constexpr (kFriction) {
      // Levers to the middle of the overlap: (r_i - delta/2) n from i, -(r_j - delta/2) n from j.
      const V lever_i = ri - half * positive_overlap;
      const V lever_j = rj - half * positive_overlap;
      const Lanes3<D> arm_i{lever_i * n.x, lever_i * n.y, lever_i * n.z};
      const Lanes3<D> arm_j{hn::Neg(lever_j * n.x), hn::Neg(lever_j * n.y), hn::Neg(lever_j * n.z)};
      const Lanes3<D> spin_i{hn::Load(d, b.wix + s), hn::Load(d, b.wiy + s),
                             hn::Load(d, b.wiz + s)};
      const Lanes3<D> spin_j{hn::Load(d, b.wjx + s), hn::Load(d, b.wjy + s),
                             hn::Load(d, b.wjz + s)};
      const Lanes3<D> turn_j = cross(spin_j, arm_j);
      const Lanes3<D> turn_i = cross(spin_i, arm_i);
      const Lanes3<D> relative{dv.x + turn_j.x - turn_i.x, dv.y + turn_j.y - turn_i.y,
                               dv.z + turn_j.z - turn_i.z};
      const Lanes3<D> sliding = tangential_part(relative, n);
      Lanes3<D> spring{load_lanes(d, history.sx.data() + k, valid),
                       load_lanes(d, history.sy.data() + k, valid),
                       load_lanes(d, history.sz.data() + k, valid)};
      const V k_t = constant(8, c0.eight_g, s) * a_contact;
      const V d_t =
          constant(2, c0.two_xi_contact, s) * h.root_mk * constant(9, c0.tangential_ratio, s);
      const Lanes3<D> friction = tangential_lanes(
          d, contact, k_t, d_t, constant(10, c0.friction, s) * load, n, sliding, dt, spring);
      force = {force.x + friction.x, force.y + friction.y, force.z + friction.z};
      const Lanes3<D> per_lever = cross(n, friction);
      lever_slot = {hn::IfThenElseZero(contact, per_lever.x),
                    hn::IfThenElseZero(contact, per_lever.y),
                    hn::IfThenElseZero(contact, per_lever.z)};
      if (records == nullptr) {  // else stored with the force below
        store_slot(d, lever_slot.x, valid, slot(3, k), a.stream_slots);
        store_slot(d, lever_slot.y, valid, slot(4, k), a.stream_slots);
        store_slot(d, lever_slot.z, valid, slot(5, k), a.stream_slots);
        store_slot(d, positive_overlap, valid, slot(6, k), a.stream_slots);
      }
      store_lanes(d, hn::IfThenElseZero(contact, spring.x), valid, history.sx.data() + k);
      store_lanes(d, hn::IfThenElseZero(contact, spring.y), valid, history.sy.data() + k);
      store_lanes(d, hn::IfThenElseZero(contact, spring.z), valid, history.sz.data() + k);
      if (a.rolling) {
        // A solid sphere's I = 0.4 m r^2 (Particles::inverse_inertia).
        const V two_fifths = hn::Set(d, 0.4);
        const Lanes3<D> roll =
            rolling_lanes(d, contact, constant(11, c0.rolling_friction, s), r_star, load,
                          two_fifths * mi * ri * ri, two_fifths * mj * rj * rj,
                          {spin_i.x - spin_j.x, spin_i.y - spin_j.y, spin_i.z - spin_j.z}, dt);
        store_lanes(d, roll.x, valid, out.roll_x.data() + k);
        store_lanes(d, roll.y, valid, out.roll_y.data() + k);
        store_lanes(d, roll.z, valid, out.roll_z.data() + k);
      }
    }
    const Lanes3<D> force_slot{hn::IfThenElseZero(contact, force.x),
                               hn::IfThenElseZero(contact, force.y),
                               hn::IfThenElseZero(contact, force.z)};
    if (records != nullptr) {
      store_records(d, force_slot, positive_overlap, lever_slot, valid,
                    records + 8 * std::size_t{k});
    } else {
      store_slot(d, force_slot.x, valid, slot(0, k), a.stream_slots);
      store_slot(d, force_slot.y, valid, slot(1, k), a.stream_slots);
      store_slot(d, force_slot.z, valid, slot(2, k), a.stream_slots);
    }
    tally.contacts += hn::CountTrue(d, contact);
    tally.bonds += hn::CountTrue(d, bonded);
    // Largest overlap and overlap / smaller radius; max is exact, so any lane order agrees. The
    // division is made only where the ratio may exceed the lane's maximum m: a ratio that rounds
    // above m has overlap > m r (1 + 2^-53), above m r rounded and shrunk by 2^-50.
    max_overlap = hn::IfThenElse(positive_overlap > max_overlap, positive_overlap, max_overlap);
    const V smaller = hn::IfThenElse(ri < rj, ri, rj);
    const M may_exceed = positive_overlap > max_fraction * smaller * hn::Set(d, 1.0 - 0x1p-50);
    if (!hn::AllFalse(d, may_exceed)) {
      const V fraction = positive_overlap / hn::IfThenElse(may_exceed, smaller, one);
      max_fraction =
          hn::IfThenElse(hn::And(may_exceed, fraction > max_fraction), fraction, max_fraction);
    }
  }
  HWY_ALIGN double lane_values[hn::MaxLanes(d)];
  hn::Store(max_overlap, d, lane_values);
  for (std::size_t l = 0; l < lanes; ++l)
    tally.max_overlap = std::max(tally.max_overlap, lane_values[l]);
  hn::Store(max_fraction, d, lane_values);
  for (std::size_t l = 0; l < lanes; ++l) {
    tally.max_fraction = std::max(tally.max_fraction, lane_values[l]);
  }
}

/// Whether the @p count flags at @p flags are all 0, eight at a time.
HWY_INLINE bool none_set(const std::uint8_t* flags, std::uint32_t count) {
  std::uint64_t any = 0;
  std::uint32_t s = 0;
  for (; s + 8 <= count; s += 8) {
    std::uint64_t word;
    std::memcpy(&word, flags + s, sizeof word);
    any |= word;
  }
  for (; s < count; ++s) any |= flags[s];
  return any == 0;
}

/// Whether some pair of [@p first_k, first_k + @p count) is kept (LanePassArgs::kept).
HWY_INLINE bool any_kept(const KeptPairs& kept, std::uint32_t first_k, std::uint32_t count) {
  for (int w = 0; w < kept.window_count; ++w) {
    if (first_k < kept.windows[3 * w + 1] && first_k + count > kept.windows[3 * w]) return true;
  }
  const std::uint32_t end = first_k + count;
  for (std::uint32_t word = first_k >> 6; word <= (end - 1) >> 6; ++word) {
    std::uint64_t bits = kept.bits[word];
    if (word == first_k >> 6) bits &= ~std::uint64_t{0} << (first_k & 63);
    if (word == (end - 1) >> 6 && (end & 63) != 0) bits &= (std::uint64_t{1} << (end & 63)) - 1;
    if (bits != 0) return true;
  }
  return false;
}

/// Copies the records (or slots) of the kept pairs of [@p first_k, first_k + @p count) from the
/// ring into their kept records (LanePassArgs::kept).
HWY_INLINE void keep_pairs(const detail::LanePassArgs& a, std::uint32_t first_k,
                           std::uint32_t count) {
  const KeptPairs& kept = *a.kept;
  for (std::uint32_t k = first_k; k < first_k + count; ++k) {
    if (!kept.kept(k)) continue;
    double* to = kept.record(k);
    if (a.records != nullptr) {
      std::copy(a.records + 8 * std::size_t{k - a.slot_shift},
                a.records + 8 * std::size_t{k - a.slot_shift} + 8, to);
    } else {  // without friction: the force alone
      for (int v = 0; v < 3; ++v) to[v] = a.slots[v][k - a.slot_shift];
    }
  }
}

/// Pass 1 over rows [@p first_row, @p last_row), one thread's share of the particles: pack,
/// evaluate and unpack block by block. One call per thread: a call per 64 rows (the chunks of
/// the scalar pass) restarted the blocks at every chunk and ran 2 % slower on the 20 800 peer
/// lattice (5 alternating runs).
template <bool kFriction>
ContactSummary LanePass(const detail::LanePassArgs& a, std::size_t first_row,
                        std::size_t last_row) {
  const hn::ScalableTag<double> d;
  const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
  const StaggeredVector<std::uint32_t>& row_begin = a.list->row_begins();
  PairForces& out = *a.out;
  PairBlock b;
  LaneTally tally;
  ContactSummary summary;
  std::size_t row = first_row;
  const std::uint32_t pairs_end = row_begin[last_row];
  for (std::uint32_t block = row_begin[first_row], count = 0; block < pairs_end; block += count) {
    // Blocks end on multiples of 8 pairs (a call's first may be shorter), so that the slots' whole
    // vectors start on their own alignment, which streaming stores need. Pairs are independent:
    // how they are blocked changes no value.
    count = std::min(pairs_end, (block + kLaneBlock) & ~std::uint32_t{7}) - block;
    while (row_begin[row + 1] <= block) ++row;
    for (std::uint32_t s = 0;;) {
      const std::uint32_t row_end = std::min(row_begin[row + 1] - block, count);
      broadcast_row<kFriction>(*a.particles, b, static_cast<std::uint32_t>(row), s, row_end);
      s = row_end;
      if (s == count) break;
      ++row;
    }
    // The next block's j particles, while this one is gathered and evaluated: by the gather's
    // own loops (pack_block), or here where it reads the records (set only in tests and
    // benchmarks above the prefetch count).
    const std::uint32_t next = block + count;
    const std::uint32_t* next_js = nullptr;
    if (a.prefetch && next < pairs_end) {
      const std::uint32_t next_count = std::min(pairs_end - next, kLaneBlock);
      const std::uint32_t* js = a.list->seconds() + next;
      // A shorter next block (the last) is left to the hardware.
      if (a.kinematics == nullptr && next_count >= count) next_js = js;
      const Particles& p = *a.particles;
      if (a.kinematics != nullptr) {
        for (std::uint32_t s = 0; s < next_count; ++s) {
          const std::uint32_t j = js[s];
          __builtin_prefetch(a.kinematics + 4 * std::size_t{j});
          __builtin_prefetch(a.kinematics + 4 * (p.size() + j));
          if (a.spins != nullptr) {
            __builtin_prefetch(a.spins + 4 * std::size_t{j});
          } else if constexpr (kFriction) {
            __builtin_prefetch(p.wx.data() + j);
            __builtin_prefetch(p.wy.data() + j);
            __builtin_prefetch(p.wz.data() + j);
          }
        }
      }
    }
    pack_block<kFriction>(a, b, block, count, next_js);
    pad_block(b, count, (count + lanes - 1) / lanes * lanes);
    const std::size_t bonds_before = tally.bonds;
    evaluate_block<kFriction>(a, b, block, count, tally);
    if (a.kept != nullptr && any_kept(*a.kept, block, count)) keep_pairs(a, block, count);
    if (a.counted == nullptr) {  // every pair counted: a loop without branches
      std::uint8_t* HWY_RESTRICT flags = out.bonded.data() + block;
      // No pair of the block bonded, before or now (most blocks of most runs): the flags stay 0.
      if (tally.bonds == bonds_before && none_set(flags, count)) continue;
      std::size_t formed = 0, broken = 0;
      for (std::uint32_t s = 0; s < count; ++s) {
        const std::uint8_t now = b.bonded[s] > 0.0 ? 1 : 0;
        const std::uint8_t before = flags[s];
        flags[s] = now;
        formed += now > before ? 1 : 0;
        broken += now < before ? 1 : 0;
      }
      summary.bonds_formed += formed;
      summary.bonds_broken += broken;
      continue;
    }
    for (std::uint32_t s = 0; s < count; ++s) {
      const std::uint8_t now = b.bonded[s] > 0.0 ? 1 : 0;
      const std::uint8_t before = out.bonded[block + s];
      out.bonded[block + s] = now;
      if (a.counted[b.first[s]] == 0) {
        // Another rank counts this pair: take back what the lanes tallied of it.
        tally.contacts -= b.overlap[s] > 0.0 ? 1 : 0;
        tally.bonds -= now;
        continue;
      }
      summary.bonds_formed += now > before ? 1 : 0;
      summary.bonds_broken += now < before ? 1 : 0;
    }
  }
  // The streamed slots are visible to every thread once the stores are ordered before the join.
  if (a.stream_slots) hwy::FlushStream();
  summary.contacts = tally.contacts;
  summary.bonds = tally.bonds;
  summary.max_overlap = tally.max_overlap;
  summary.max_overlap_fraction = tally.max_fraction;
  return summary;
}

/// Writes the quadruples of particles [@p first, @p end) of LanePassArgs::kinematics, at
/// @p records (8 n doubles): (x, y, z, r) at records + 4 i, (vx, vy, vz, m) at records + 4 n + 4 i;
/// and where @p spins is set (LanePassArgs::spins), (wx, wy, wz, 0) at spins + 4 i.
void FillKinematics(const Particles& p, std::size_t first, std::size_t end, double* records,
                    double* spins) {
  const hn::ScalableTag<double> d;
  const std::size_t lanes = hn::Lanes(d);
  double* HWY_RESTRICT positions = records;
  double* HWY_RESTRICT velocities = records + 4 * p.size();
  if (spins != nullptr) {
    double* HWY_RESTRICT turning = spins;
    std::size_t i = first;
    for (; i + lanes <= end; i += lanes) {
      hn::StoreInterleaved4(hn::LoadU(d, p.wx.data() + i), hn::LoadU(d, p.wy.data() + i),
                            hn::LoadU(d, p.wz.data() + i), hn::Zero(d), d, turning + 4 * i);
    }
    for (; i < end; ++i) {
      turning[4 * i] = p.wx[i];
      turning[4 * i + 1] = p.wy[i];
      turning[4 * i + 2] = p.wz[i];
      turning[4 * i + 3] = 0.0;
    }
  }
  std::size_t i = first;
  for (; i + lanes <= end; i += lanes) {
    hn::StoreInterleaved4(hn::LoadU(d, p.x.data() + i), hn::LoadU(d, p.y.data() + i),
                          hn::LoadU(d, p.z.data() + i), hn::LoadU(d, p.radius.data() + i), d,
                          positions + 4 * i);
    hn::StoreInterleaved4(hn::LoadU(d, p.vx.data() + i), hn::LoadU(d, p.vy.data() + i),
                          hn::LoadU(d, p.vz.data() + i), hn::LoadU(d, p.mass.data() + i), d,
                          velocities + 4 * i);
  }
  for (; i < end; ++i) {
    positions[4 * i] = p.x[i];
    positions[4 * i + 1] = p.y[i];
    positions[4 * i + 2] = p.z[i];
    positions[4 * i + 3] = p.radius[i];
    velocities[4 * i] = p.vx[i];
    velocities[4 * i + 1] = p.vy[i];
    velocities[4 * i + 2] = p.vz[i];
    velocities[4 * i + 3] = p.mass[i];
  }
}

ContactSummary LanePassWithFriction(const detail::LanePassArgs& a, std::size_t first_row,
                                    std::size_t last_row) {
  return LanePass<true>(a, first_row, last_row);
}
ContactSummary LanePassWithoutFriction(const detail::LanePassArgs& a, std::size_t first_row,
                                       std::size_t last_row) {
  return LanePass<false>(a, first_row, last_row);
}

}  // namespace bondem::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace bondem {

HWY_EXPORT(LanePassWithFriction);
HWY_EXPORT(GatherRecords);
HWY_EXPORT(FillKinematics);
HWY_EXPORT(LanePassWithoutFriction);

namespace {
/// Highway's bit for each target, in SimdTarget order after kAuto.
struct TargetBit {
  SimdTarget target;
  const char* name;
  std::int64_t bit;
};
constexpr TargetBit kTargetBits[] = {{SimdTarget::kScalar, "scalar", HWY_SCALAR},
                                     {SimdTarget::kSse4, "sse4", HWY_SSE4},
                                     {SimdTarget::kAvx2, "avx2", HWY_AVX2},
                                     {SimdTarget::kAvx512, "avx512", HWY_AVX3}};

/// The targets both compiled in (HWY_TARGETS) and supported by this CPU.
std::int64_t usable_bits() {
  return hwy::SupportedTargets() & HWY_TARGETS;
}

SimdTarget selected = SimdTarget::kAuto;
}  // namespace

std::optional<SimdTarget> parse_simd_target(std::string_view name) {
  if (name == "auto") return SimdTarget::kAuto;
  for (const TargetBit& t : kTargetBits) {
    if (name == t.name) return t.target;
  }
  return std::nullopt;
}

const char* simd_target_name(SimdTarget target) {
  for (const TargetBit& t : kTargetBits) {
    if (t.target == target) return t.name;
  }
  return "auto";
}

std::vector<SimdTarget> supported_simd_targets() {
  std::vector<SimdTarget> targets;
  for (const TargetBit& t : kTargetBits) {
    if ((usable_bits() & t.bit) != 0) targets.push_back(t.target);
  }
  return targets;
}

void select_simd_target(SimdTarget target) {
  const std::vector<SimdTarget> usable = supported_simd_targets();
  if (target == SimdTarget::kAuto) target = usable.back();
  if (std::find(usable.begin(), usable.end(), target) == usable.end()) {
    std::string names;
    for (SimdTarget t : usable)
      names += std::string(names.empty() ? "" : ", ") + simd_target_name(t);
    throw std::invalid_argument(std::string("SIMD target '") + simd_target_name(target) +
                                "' is not supported by this CPU (supported: " + names + ")");
  }
  for (const TargetBit& t : kTargetBits) {
    if (t.target == target) hwy::GetChosenTarget().Update(t.bit);
  }
  selected = target;
}

SimdTarget simd_target_in_use() {
  if (selected == SimdTarget::kAuto) select_simd_target(SimdTarget::kAuto);
  return selected;
}

const char* scalar_pass_reason(const NormalLawSpec& law, const std::vector<PairCoefficients>& pairs,
                               bool thermal) {
  if (!std::holds_alternative<BondLawSpec>(law)) return "the Hooke law";
  if (thermal) return "heat conduction";
  for (const PairCoefficients& c : pairs) {
    if (c.alpha != 1.0) return "an adhesion exponent alpha != 1 (std::pow)";
    if (c.cohesion == CohesionModel::kSjkr) return "sJKR cohesion";
    if (c.cohesion == CohesionModel::kJkr) return "JKR cohesion";
    if (c.rolling_friction != 0.0 && c.rolling_model == RollingModel::kEpsd) {
      return "EPSD rolling resistance";
    }
  }
  return nullptr;
}

bool simd_pass_applies(const Scene& scene) {
  return scalar_pass_reason(scene.normal_law, scene.pair_table, scene.particles.thermal()) ==
         nullptr;
}

std::vector<LanePairConstants> lane_pair_constants(const Scene& scene) {
  std::vector<LanePairConstants> constants;
  for (const PairCoefficients& c : scene.pair_table) {
    LanePairConstants l;
    l.four_thirds_e = 4.0 / 3.0 * c.effective_modulus;
    l.two_e = 2.0 * c.effective_modulus;
    l.two_xi_contact = 2.0 * c.contact_damping;
    l.two_xi_bond = 2.0 * c.bond_damping;
    const bool stiffness_input = c.input == AdhesionInput::kStiffness;
    l.stiffness_input = stiffness_input ? 1.0 : 0.0;
    l.equilibrium_overlap = stiffness_input ? 0.0 : c.equilibrium_overlap;
    l.adhesion_stiffness = stiffness_input ? c.adhesion_stiffness : 0.0;
    l.critical_ratio = c.critical_ratio;
    l.eight_g = 8.0 * c.shear_modulus;
    l.tangential_ratio =
        c.effective_modulus > 0.0 ? std::sqrt(4.0 * c.shear_modulus / c.effective_modulus) : 0.0;
    l.friction = c.friction;
    l.rolling_friction = c.rolling_friction;
    constants.push_back(l);
  }
  return constants;
}

/// Particles from which pass 1 prefetches the next block's j particles. Out of cache, the gather
/// reads 11 arrays at three j streams each, more streams than the hardware prefetchers follow:
/// prefetching made the 998 400 peer lattice 6 % faster (three alternating runs) and friction pass
/// 1 at 64 000 particles 18 % faster (bench_kernel); in cache it is pure overhead (the 20 800
/// lattice 5 % slower, pass 1 at 8 000 particles 10-14 %).
constexpr std::size_t kPrefetchParticles = 32768;

namespace {
/// set_kinematics_records_below's limit: the records are read below 2^19 particles. Transposed
/// in registers (load_transposed) they pay at every size measured on this Zen 5: bench_step
/// RecordsPaired, one thread, 0.90 at 1 300 and 20 800 spheres, 0.97 at 130 000, 0.99 at 997 477;
/// whole runs of the 20 800 peer lattice 0.92 (8 alternating rounds, 0.88-0.93) on AVX-512,
/// 0.92-0.94 on AVX2, 0.99 on SSE4. Copied through memory and read back as vectors, as before, they
/// lost (0.96 at 20 800 on AVX-512 here, 1.01-1.03 on AVX2, 1.05 on SSE4; whole runs on the Zen 4
/// of earlier sessions 1.08). From 2^19 on their 64 B a particle (13 % of a step's memory) would
/// buy about 1 % and cost the memory target of 500 B a particle at 10^6.
std::atomic<std::size_t> records_below{std::size_t{1} << 19};

/// Whether a pass over @p particles particles reads kinematics records (the sweep then writes
/// them).
bool reads_records(std::size_t particles) {
  return particles < records_below.load(std::memory_order_relaxed);
}

/// Particles from which the lanes stream the force slots past the caches. Where the step's data
/// outgrows the 32 MiB L3 here, the slots' lines are otherwise read from memory before they are
/// overwritten and evict the particle data the pass gathers. bench_step StreamPaired, one thread,
/// steps paired in one process (streamed / cached): 1.000-1.005 at 32 500 and 46 800 spheres,
/// 0.96-0.98 at 63 700, 0.94 at 83 200, 0.93-1.00 at 130 000, 0.96-1.00 at 997 477 (0.98 on two
/// threads); the gain shrinks in the hours when the host's memory is fast.
constexpr std::size_t kStreamSlotsParticles = 56 * 1024;

/// set_stream_pair_slots_from's limit.
std::atomic<std::size_t> stream_slots_from{kStreamSlotsParticles};
}  // namespace

std::size_t set_stream_pair_slots_from(std::size_t particles) {
  return stream_slots_from.exchange(particles, std::memory_order_relaxed);
}

bool pass_reads_records(std::size_t particles) {
  return reads_records(particles);
}

std::size_t set_kinematics_records_below(std::size_t particles) {
  return records_below.exchange(particles, std::memory_order_relaxed);
}

bool records_hold_spins(bool friction) {
  return friction && simd_target_in_use() == SimdTarget::kAvx512;
}

namespace {
/// @p scratch's records sized for @p particles particles of a run with @p friction, and where
/// they lie: the position and velocity quadruples, then the spins' where records_hold_spins.
SweepRecords size_records(LanePassScratch& scratch, std::size_t particles, bool friction) {
  const bool spins = records_hold_spins(friction);
  scratch.kinematics.resize((spins ? 12 : 8) * particles);
  double* const records = scratch.kinematics.data();
  return {records, spins ? records + 8 * particles : nullptr};
}
}  // namespace

SweepRecords current_records(const Particles& p, bool friction, LanePassScratch& scratch) {
  const std::size_t n = p.size();
  const std::size_t sized_before = scratch.kinematics.size();
  const SweepRecords records = size_records(scratch, n, friction);
  if (!scratch.current || scratch.kinematics.size() != sized_before) {
    const auto fill = HWY_DYNAMIC_DISPATCH(FillKinematics);
    const auto chunks = static_cast<std::int64_t>((n + kPairPassChunk - 1) / kPairPassChunk);
#pragma omp parallel for schedule(static) if (chunks > 1)
    for (std::int64_t c = 0; c < chunks; ++c) {
      const std::size_t first = static_cast<std::size_t>(c) * kPairPassChunk;
      fill(p, first, std::min(n, first + kPairPassChunk), records.kinematics, records.spins);
    }
  }
  scratch.current = false;  // the particles move on after this pass
  return records;
}

SweepRecords records_for_sweep(LanePassScratch& scratch, std::size_t particles, bool friction,
                               bool fused) {
  if (!fused && !reads_records(particles)) return {};
  return size_records(scratch, particles, friction);
}

namespace {
/// set_pair_records_below's limit. Measured on the 20 800 peer lattice only (whole runs 0.90 on
/// AVX-512, 8 alternating rounds); a test program of pass 2 alone at 10^6 took 1.23 times as long
/// with records (64 B a pair where the arrays read 56, and the pair's line whole at every column
/// visit), so they stop where the step's data leaves the L3, where the slots start to stream.
std::atomic<std::size_t> pair_records_below{kStreamSlotsParticles};
}  // namespace

std::size_t set_pair_records_below(std::size_t particles) {
  return pair_records_below.exchange(particles, std::memory_order_relaxed);
}

bool keeps_pair_records(std::size_t particles, bool friction, bool rolling, bool thermal) {
  return friction && !rolling && !thermal &&
         particles < pair_records_below.load(std::memory_order_relaxed);
}

void gather_record_range(Particles& p, const NeighborList& list, const double* records,
                         const Eigen::Vector3d& gravity, std::size_t first, std::size_t end,
                         std::uint32_t mask) {
  HWY_DYNAMIC_DISPATCH(GatherRecords)
  (p, list, records, gravity.x(), gravity.y(), gravity.z(), first, end, mask);
}

namespace {
/// What a call of the pass sets up: the periodic shifts by image code and the pass's arguments,
/// which point at them.
struct LaneSetup {
  double shift_x[27], shift_y[27], shift_z[27];
  detail::LanePassArgs args;
};

/// Sets up @p setup for a pass over the pairs of @p list that writes their slots into @p out's
/// arrays (LanePassArgs::slots), reading @p records where they are set.
void prepare_lanes(LaneSetup& setup, const Particles& p, const Scene& scene,
                   const NeighborList& list, std::span<const LanePairConstants> constants,
                   const BondingCriterion& criterion_met, PairForces& out, PairHistory& history,
                   const std::uint8_t* counted, const SweepRecords& records) {
  simd_target_in_use();  // chooses the best target on first use
  for (std::size_t code = 0; code < 27; ++code) {
    setup.shift_x[code] = list.shift_table()[code].x();
    setup.shift_y[code] = list.shift_table()[code].y();
    setup.shift_z[code] = list.shift_table()[code].z();
  }
  // The criterion is the same for every pair when every material pair never or always bonds.
  const auto all = [&](BondCriterion criterion) {
    return std::all_of(scene.pair_table.begin(), scene.pair_table.end(),
                       [&](const PairCoefficients& c) { return c.criterion == criterion; });
  };
  const int uniform_criterion =
      all(BondCriterion::kNever) ? 0 : (all(BondCriterion::kAlways) ? 1 : -1);
  const std::size_t n = p.size();
  setup.args = detail::LanePassArgs{&p,
                                    &scene,
                                    &list,
                                    constants.data(),
                                    &criterion_met,
                                    &out,
                                    &history,
                                    constants.size() == 1,
                                    !out.roll_x.empty(),
                                    uniform_criterion,
                                    setup.shift_x,
                                    setup.shift_y,
                                    setup.shift_z,
                                    counted,
                                    n >= kPrefetchParticles,
                                    records.kinematics,
                                    records.spins,
                                    n >= stream_slots_from.load(std::memory_order_relaxed),
                                    {out.fx.data(), out.fy.data(), out.fz.data(), out.cx.data(),
                                     out.cy.data(), out.cz.data(), out.overlap.data()},
                                    0,
                                    out.in_records() ? out.records.data() : nullptr,
                                    nullptr};
}
}  // namespace

ContactSummary simd_pair_forces(const Particles& p, const Scene& scene, const NeighborList& list,
                                std::span<const LanePairConstants> constants,
                                const BondingCriterion& criterion_met, PairForces& out,
                                PairHistory& history, const std::uint8_t* counted,
                                ThreadSplit* split, LanePassScratch* scratch) {
  const std::size_t n = p.size();
  const std::size_t chunks = (n + kPairPassChunk - 1) / kPairPassChunk;
  ThreadSplit equal_shares;
  if (split == nullptr) split = &equal_shares;
  // Each thread one contiguous run of chunks, so that its rows are about the particles its
  // sweeps and pass 2 take.
  split->prepare(chunks, threads_in_use(n));
  LanePassScratch own_scratch;
  if (scratch == nullptr) scratch = &own_scratch;
  SweepRecords records;
  if (reads_records(n)) {
    // In cache by default (below the count that prefetches): each pair then reads two quadruples
    // of each of its particles instead of eight arrays, written by the opening sweep or else copied
    // here. A region of its own: a thread's pairs read particles of the other threads' shares.
    // Records of another size (another target's layout, another count) are not the sweep's.
    const std::size_t sized_before = scratch->kinematics.size();
    records = size_records(*scratch, n, scene.friction);
    if (!scratch->current || scratch->kinematics.size() != sized_before) {
      const int shares = split->threads();
      const auto fill = HWY_DYNAMIC_DISPATCH(FillKinematics);
#pragma omp parallel num_threads(shares) if (shares > 1)
      for (int t = omp_get_thread_num(); t < shares; t += omp_get_num_threads()) {
        fill(p, std::min(n, split->begin(t) * kPairPassChunk),
             std::min(n, split->begin(t + 1) * kPairPassChunk), records.kinematics, records.spins);
      }
    }
  } else {
    StaggeredVector<double>().swap(scratch->kinematics);  // a run that grew past the threshold
  }
  scratch->current = false;  // the particles move on after this pass
  LaneSetup setup;
  prepare_lanes(setup, p, scene, list, constants, criterion_met, out, history, counted, records);
  const detail::LanePassArgs& args = setup.args;
  const auto pass = scene.friction ? HWY_DYNAMIC_DISPATCH(LanePassWithFriction)
                                   : HWY_DYNAMIC_DISPATCH(LanePassWithoutFriction);
  return split->run(
      ContactSummary{},
      [&](int, std::size_t first_chunk, std::size_t end_chunk) {
        return pass(args, std::min(n, first_chunk * kPairPassChunk),
                    std::min(n, end_chunk * kPairPassChunk));
      },
      add_pair_summary);
}

ContactSummary simd_pair_forces_fused(const Particles& p, const Scene& scene,
                                      const NeighborList& list,
                                      std::span<const LanePairConstants> constants,
                                      const BondingCriterion& criterion_met, PairForces& out,
                                      PairHistory& history, const FusedRing& ring,
                                      std::size_t first_row, std::size_t end_row,
                                      const SweepRecords& records,
                                      const std::function<void(std::size_t, std::size_t)>& done) {
  if (out.in_records() || !out.roll_x.empty()) {
    throw std::logic_error("simd_pair_forces_fused: a pass with pair records or rolling slots");
  }
  LaneSetup setup;
  prepare_lanes(setup, p, scene, list, constants, criterion_met, out, history, nullptr, records);
  detail::LanePassArgs& args = setup.args;
  args.stream_slots = false;  // the ring stays in the caches
  args.kept = &ring.kept;
  for (int v = 0; v < 7; ++v) args.slots[v] = ring.slots[v];
  args.records = ring.records;
  const int arrays = scene.friction ? 7 : 3;
  const auto pass = scene.friction ? HWY_DYNAMIC_DISPATCH(LanePassWithFriction)
                                   : HWY_DYNAMIC_DISPATCH(LanePassWithoutFriction);
  const StaggeredVector<std::uint32_t>& row_begin = list.row_begins();
  const std::uint32_t mask = ring.pairs - 1;
  ContactSummary summary;
  for (std::size_t row = first_row; row < end_row;) {
    const std::size_t end = std::min(end_row, (row / ring.run_rows + 1) * ring.run_rows);
    const std::uint32_t first_k = row_begin[row];
    const std::uint32_t pairs = row_begin[end] - first_k;
    if (pairs > ring.pairs)
      throw std::logic_error("simd_pair_forces_fused: a run outgrows the ring");
    // The run's slots lie contiguous from first_k mod ring.pairs; what passes the ring's end is
    // moved to its front, so that pair k's slots lie at k mod ring.pairs.
    const std::uint32_t start = first_k & mask;
    args.slot_shift = first_k - start;
    add_pair_summary(summary, pass(args, row, end));
    if (start + pairs > ring.pairs && ring.records != nullptr) {
      std::copy(ring.records + 8 * std::size_t{ring.pairs},
                ring.records + 8 * (std::size_t{start} + pairs), ring.records);
    } else if (start + pairs > ring.pairs) {
      for (int v = 0; v < arrays; ++v) {
        std::copy(ring.slots[v] + ring.pairs, ring.slots[v] + start + pairs, ring.slots[v]);
      }
    }
    done(row, end);
    row = end;
  }
  return summary;
}

}  // namespace bondem
#endif  // HWY_ONCE
