// ExactSum: exact, order-free totals rounded once.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "solver/engine/exact_sum.hpp"

namespace bondem {
namespace {

__extension__ typedef __int128 Int128;  // the oracle's exact integer (a GCC and Clang extension)

double exact_total(const std::vector<double>& terms) {
  ExactSum sum;
  for (const double term : terms) sum.add(term);
  return sum.value();
}

TEST(ExactSum, MatchesAnIntegerOracleOnFixedPointTerms) {
  // Terms that are whole multiples of 2^-60 below 2^40 in magnitude: their exact total is an
  // integer multiple of 2^-60 that __int128 holds, and converting that integer to double rounds
  // to nearest-even once: an oracle independent of ExactSum's digits. The exponents vary over
  // 100 binades, so floating-point summation loses low bits that the oracle keeps.
  std::mt19937_64 random(2026);
  std::uniform_int_distribution<int> binade(-60, 39);
  std::uniform_int_distribution<std::int64_t> mantissa(0, (std::int64_t{1} << 53) - 1);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> terms;
    Int128 oracle = 0;
    for (int t = 0; t < 300; ++t) {
      const int e = binade(random);
      const int scale = std::max(e - 52, -60);  // the term's last bit, not below 2^-60
      const std::int64_t bits = mantissa(random) >> std::max(0, -60 - (e - 52));
      const std::int64_t m = (t % 3 == 0) ? -bits : bits;
      terms.push_back(std::ldexp(static_cast<double>(m), scale));
      oracle += static_cast<Int128>(m) << (scale + 60);
    }
    const double expected = std::ldexp(static_cast<double>(oracle), -60);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(exact_total(terms)),
              std::bit_cast<std::uint64_t>(expected))
        << "trial " << trial;
  }
}

TEST(ExactSum, SameBytesInAnyOrderAndAnySplit) {
  // Terms spanning 10^-300 .. 10^300 with both signs: any order, or two partial sums merged,
  // give the same bytes (plain summation gives several different results here).
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> exponent(-300.0, 300.0);
  std::vector<double> terms;
  for (int t = 0; t < 2000; ++t) {
    terms.push_back((t % 2 == 0 ? 1.0 : -1.0) * std::pow(10.0, exponent(random)));
  }
  const double reference = exact_total(terms);
  bool plain_differs = false;
  double plain_reference = 0.0;
  for (const double term : terms) plain_reference += term;
  for (int shuffle = 0; shuffle < 20; ++shuffle) {
    std::shuffle(terms.begin(), terms.end(), random);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(exact_total(terms)),
              std::bit_cast<std::uint64_t>(reference));
    ExactSum first, second;
    const std::size_t cut = terms.size() * static_cast<std::size_t>(shuffle) / 20;
    for (std::size_t t = 0; t < terms.size(); ++t) (t < cut ? first : second).add(terms[t]);
    first += second;
    EXPECT_EQ(std::bit_cast<std::uint64_t>(first.value()), std::bit_cast<std::uint64_t>(reference));
    double plain = 0.0;
    for (const double term : terms) plain += term;
    plain_differs = plain_differs || plain != plain_reference;
  }
  EXPECT_TRUE(plain_differs) << "the terms do not exercise the order dependence they test";
}

TEST(ExactSum, CancellationRoundingAndLimits) {
  // 10^300 + 1 - 10^300 is 1 exactly (0 in floating point).
  EXPECT_EQ(exact_total({1e300, 1.0, -1e300}), 1.0);
  // 2^53 + 1 is a tie: to even (2^53); anything more below breaks the tie upwards.
  const double two53 = std::ldexp(1.0, 53);
  EXPECT_EQ(exact_total({two53, 1.0}), two53);
  EXPECT_EQ(exact_total({two53, 1.0, std::ldexp(1.0, -900)}), two53 + 2.0);
  EXPECT_EQ(exact_total({two53, 3.0}), two53 + 4.0);  // 2^53 + 3: tie, to even
  // Negative totals, and subnormals added exactly.
  EXPECT_EQ(exact_total({-two53, -1.0, -std::ldexp(1.0, -900)}), -(two53 + 2.0));
  const double tiny = std::numeric_limits<double>::denorm_min();
  EXPECT_EQ(exact_total({tiny, tiny, tiny}), 3.0 * tiny);
  EXPECT_EQ(exact_total({std::numeric_limits<double>::min(), -tiny}),
            std::numeric_limits<double>::min() - tiny);
  // Overflow of the total, infinities and NaN behave as floating point does.
  const double big = std::numeric_limits<double>::max();
  EXPECT_EQ(exact_total({big, big}), std::numeric_limits<double>::infinity());
  EXPECT_EQ(exact_total({big, big, -big}), big);  // exact: no intermediate overflow
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(exact_total({1.0, -inf}), -inf);
  EXPECT_TRUE(std::isnan(exact_total({inf, -inf})));
  EXPECT_EQ(exact_total({}), 0.0);
  EXPECT_EQ(exact_total({0.5, -0.5}), 0.0);
}

}  // namespace
}  // namespace bondem
