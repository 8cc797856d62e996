#pragma once
/// @file exact_sum.hpp
/// Exact sums of doubles: the same bytes whatever the order of the terms.

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>

namespace bondem {

/// Sum of doubles held exactly, as a fixed-point integer over the whole double range (a Kulisch
/// accumulator in 32-bit digits), rounded once to the nearest double by value(). Floating-point
/// addition is not associative, so a total over particles summed in storage order changes with
/// that order; this one does not: adding the same terms in any order, or in parts merged with
/// +=, gives the same digits, so totals are the same bytes after reordering and (merging the
/// digits as integers) across domain decompositions. About 4 ns a term; 552 bytes.
class ExactSum {
 public:
  /// Adds @p value exactly; infinities and NaN make the sum non-finite as in floating point.
  void add(double value) {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(value);
    const std::uint32_t exponent = static_cast<std::uint32_t>(bits >> 52) & 0x7ffU;
    if (exponent == 0x7ffU) {
      special_ += value;  // inf + inf = inf, inf - inf = NaN, NaN stays: order-free as well
      return;
    }
    std::uint64_t mantissa = bits & ((std::uint64_t{1} << 52) - 1);
    // value = mantissa * 2^(shift - 1074): subnormals have exponent 0 and no hidden bit.
    std::uint32_t shift = 0;
    if (exponent != 0) {
      mantissa |= std::uint64_t{1} << 52;
      shift = exponent - 1;
    }
    if (mantissa == 0) return;
    const std::int64_t sign = (bits >> 63) != 0 ? -1 : 1;
    // The mantissa shifted within its first digit spans 84 bits: three digits of at most 32 bits
    // each. An int64 digit takes 2^31 of them before it could overflow; normalize() runs long
    // before that.
    const std::uint32_t within = shift % kDigitBits;
    const std::uint64_t low = mantissa << within;
    const std::uint64_t high = within == 0 ? 0 : mantissa >> (64 - within);
    std::int64_t* digit = digits_.data() + shift / kDigitBits;
    digit[0] += sign * static_cast<std::int64_t>(low & kDigitMask);
    digit[1] += sign * static_cast<std::int64_t>(low >> kDigitBits);
    digit[2] += sign * static_cast<std::int64_t>(high);
    if (++pending_ == kMaxPending) normalize();
  }

  /// Adds another exact sum (integer addition of the digits: exact and associative).
  ExactSum& operator+=(const ExactSum& other) {
    normalize();
    ExactSum copy = other;
    copy.normalize();
    for (std::size_t k = 0; k < kDigits; ++k) digits_[k] += copy.digits_[k];
    special_ += copy.special_;
    pending_ = 1;  // each digit now holds two normalized digits at most: normalize soon enough
    return *this;
  }

  /// Digits of the sum in a form whose elementwise integer sums (an MPI_SUM over processes) are
  /// the digits of the sums' sum: each in [0, 2^32), the top one signed.
  using Digits = std::array<std::int64_t, 68>;

  /// The normalized digits (see Digits) and, apart, the sum of the infinities and NaNs added.
  Digits digits() const {
    ExactSum copy = *this;
    copy.normalize();
    return copy.digits_;
  }
  /// The sum of the infinities and NaNs added (0 when none was).
  double special() const { return special_; }
  /// The sum whose digits() are @p digits (any sum of digits() of at most 2^30 sums) and whose
  /// special() is @p special.
  static ExactSum from_digits(const Digits& digits, double special) {
    ExactSum sum;
    sum.digits_ = digits;
    sum.special_ = special;
    sum.pending_ = kMaxPending - 1;  // normalize at the next term: the digits may be large
    return sum;
  }

  /// The sum rounded once to the nearest double (ties to even); overflow gives an infinity.
  double value() const {
    if (special_ != 0.0) return special_;  // an infinity or NaN was added
    ExactSum copy = *this;
    copy.normalize();
    // Two's complement across digits: the top digit carries the sign; take the magnitude.
    const bool negative = copy.digits_[kDigits - 1] < 0;
    std::array<std::uint32_t, kDigits> magnitude{};
    std::int64_t borrow = 0;
    for (std::size_t k = 0; k < kDigits; ++k) {
      std::int64_t d = negative ? -copy.digits_[k] - borrow : copy.digits_[k];
      borrow = 0;
      if (negative && d < 0) {
        d += std::int64_t{1} << kDigitBits;
        borrow = 1;
      }
      magnitude[k] = static_cast<std::uint32_t>(d);
    }
    int top = -1;  // highest set bit, in units of 2^-1074
    for (std::size_t k = kDigits; k-- > 0;) {
      if (magnitude[k] != 0) {
        top = static_cast<int>(k) * kDigitBits + std::bit_width(magnitude[k]) - 1;
        break;
      }
    }
    if (top < 0) return 0.0;
    const auto bit = [&](int position) {
      return position >= 0 && ((magnitude[static_cast<std::size_t>(position) / kDigitBits] >>
                                (static_cast<unsigned>(position) % kDigitBits)) &
                               1U) != 0;
    };
    // Keep 53 bits (fewer in the subnormal range, whose last bit is 2^-1074), then round.
    const int lowest = top - 52 > 0 ? top - 52 : 0;
    std::uint64_t kept = 0;
    for (int position = top; position >= lowest; --position) {
      kept = (kept << 1) | (bit(position) ? 1U : 0U);
    }
    bool sticky = false;
    for (int position = lowest - 2; position >= 0 && !sticky; --position) sticky = bit(position);
    const bool half = bit(lowest - 1);
    if (half && (sticky || (kept & 1U) != 0)) ++kept;  // a carry to 2^53 stays exact
    const double rounded = std::ldexp(static_cast<double>(kept), lowest - 1074);
    return negative ? -rounded : rounded;
  }

 private:
  static constexpr int kDigitBits = 32;
  static constexpr std::uint64_t kDigitMask = 0xffffffffU;
  /// Bits 0 .. 2045 + 84 of a term (2^-1074 .. 2^1024 with the mantissa's width) and headroom
  /// for carries: 68 digits.
  static constexpr std::size_t kDigits = 68;
  static constexpr int kMaxPending = 1 << 30;
  static_assert(std::tuple_size_v<Digits> == kDigits);

  /// Carries every digit's excess into the next, leaving digits in [0, 2^32) below the top one.
  void normalize() {
    for (std::size_t k = 0; k + 1 < kDigits; ++k) {
      const std::int64_t carry = digits_[k] >> kDigitBits;  // floor division by 2^32
      digits_[k] -= carry * (std::int64_t{1} << kDigitBits);
      digits_[k + 1] += carry;
    }
    pending_ = 0;
  }

  std::array<std::int64_t, kDigits> digits_{};  ///< digit k weighs 2^(32 k - 1074)
  double special_ = 0.0;                        ///< sum of the infinities and NaNs added
  int pending_ = 0;                             ///< terms added since the last normalize()
};

}  // namespace bondem
