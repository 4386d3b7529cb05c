#include "sph/stats/rounding.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace sph::gum {
namespace {

// The examples of JCGM 100:2008 (the GUM), 7.2.2 to 7.2.6.
TEST(RoundResult, StatesTheGumsExamples) {
  // 7.2.6: "if y = 10.057 62 ohm with u_c(y) = 27 mohm, y should be rounded to 10.058 ohm".
  RoundedResult r = RoundResult(10.05762, 0.027);
  EXPECT_EQ(r.value_text, "10.058");
  EXPECT_EQ(r.uncertainty_text, "0.027");
  EXPECT_EQ(r.decimals, 3);
  EXPECT_DOUBLE_EQ(r.value, 10.058);
  EXPECT_DOUBLE_EQ(r.uncertainty, 0.027);
  // 7.2.2: m_S = 100.021 47 g with u_c = 0.35 mg; 7.2.4: (100.021 47 +- 0.000 79) g, U = 0.79 mg.
  r = RoundResult(100.02147, 0.00035);
  EXPECT_EQ(r.value_text, "100.02147");
  EXPECT_EQ(r.uncertainty_text, "0.00035");
  r = RoundResult(100.02147, 0.00079);
  EXPECT_EQ(r.value_text, "100.02147");
  EXPECT_EQ(r.uncertainty_text, "0.00079");
  // 7.2.6: "a value such as u(x_i) = 28.05 kHz should be rounded down to 28 kHz".
  EXPECT_EQ(RoundResult(1000.0, 28.05).uncertainty_text, "28");
  EXPECT_EQ(RoundResult(1000.0, 28.05).value_text, "1000");
  // 7.2.6 allows u_c = 10.47 mohm "rounded up to 11 mohm"; to the nearest it is 10, 4.5 % lower:
  // two significant digits never lower it by 5 % or more, so the nearest is kept.
  EXPECT_EQ(RoundResult(0.0, 10.47).uncertainty_text, "10");
  EXPECT_EQ(RoundResult(0.0, 10.4999).uncertainty_text, "10");
}

TEST(RoundResult, AnUncertaintyStartingWithOneKeepsTwoDigits) {
  RoundedResult r = RoundResult(-61.99771, 0.01849);
  EXPECT_EQ(r.uncertainty_text, "0.018");
  EXPECT_EQ(r.value_text, "-61.998");
  r = RoundResult(351.0420, 1.04);
  EXPECT_EQ(r.uncertainty_text, "1.0");
  EXPECT_EQ(r.value_text, "351.0");
  r = RoundResult(2.0e-6, 1.0e-7);  // exactly 1 in its first digit: 1.0e-07
  EXPECT_EQ(r.uncertainty_text, "0.00000010");
  EXPECT_EQ(r.value_text, "0.00000200");
  EXPECT_EQ(r.decimals, 8);
}

TEST(RoundResult, AnUncertaintyStartingWithNineCarriesToTheNextPlace) {
  // 9.96 to two digits is 10 (not "10.0", three digits), and the value goes to the units.
  RoundedResult r = RoundResult(3.21, 9.96);
  EXPECT_EQ(r.uncertainty_text, "10");
  EXPECT_EQ(r.value_text, "3");
  EXPECT_EQ(r.decimals, 0);
  r = RoundResult(0.123456, 0.0996);
  EXPECT_EQ(r.uncertainty_text, "0.10");
  EXPECT_EQ(r.value_text, "0.12");
  r = RoundResult(0.123456, 0.0949);  // below the carry: two digits at the third decimal
  EXPECT_EQ(r.uncertainty_text, "0.095");
  EXPECT_EQ(r.value_text, "0.123");
  r = RoundResult(12345.6, 994.0);  // rounded to hundreds: a negative number of decimals
  EXPECT_EQ(r.uncertainty_text, "990");
  EXPECT_EQ(r.value_text, "12350");
  EXPECT_EQ(r.decimals, -1);
  r = RoundResult(12345.6, 996.0);
  EXPECT_EQ(r.uncertainty_text, "1000");
  EXPECT_EQ(r.value_text, "12300");
  EXPECT_EQ(r.decimals, -2);
}

TEST(RoundResult, NegativeValuesAndZeros) {
  RoundedResult r = RoundResult(-0.0004, 0.0123);  // rounds to zero: no sign
  EXPECT_EQ(r.value_text, "0.000");
  EXPECT_EQ(r.value, 0.0);
  r = RoundResult(0.0, 0.0123);
  EXPECT_EQ(r.value_text, "0.000");
  EXPECT_EQ(r.uncertainty_text, "0.012");
  r = RoundResult(-0.0006, 0.0123);
  EXPECT_EQ(r.value_text, "-0.001");
  r = RoundResult(-5.0, -0.27);  // the uncertainty's sign is ignored
  EXPECT_EQ(r.uncertainty_text, "0.27");
  EXPECT_EQ(r.value_text, "-5.00");
  // An exact value (u = 0): printed in full, nothing rounded.
  r = RoundResult(-62.0, 0.0);
  EXPECT_TRUE(r.exact);
  EXPECT_EQ(r.value_text, "-62");
  EXPECT_EQ(r.uncertainty_text, "0");
  EXPECT_EQ(r.HalfUnit(), 0.0);
  r = RoundResult(0.1 + 0.2, 0.0);
  EXPECT_EQ(r.value_text, "0.30000000000000004");
  EXPECT_EQ(RoundResult(0.0, 0.0).value_text, "0");
  EXPECT_EQ(RoundResult(-0.0, 0.0).value_text, "0");
}

TEST(RoundResult, AnUncertaintyNotKnownOrAValueNotFinite) {
  const double inf = std::numeric_limits<double>::infinity();
  RoundedResult r = RoundResult(0.0199524123, std::nan(""));
  EXPECT_FALSE(r.exact);
  EXPECT_EQ(r.value_text, "0.0199524");
  EXPECT_EQ(r.uncertainty_text, "-");
  r = RoundResult(-123.456789, inf);
  EXPECT_EQ(r.value_text, "-123.457");
  r = RoundResult(std::nan(""), 0.1);
  EXPECT_EQ(r.value_text, "-");
  EXPECT_EQ(r.uncertainty_text, "0.10");
}

TEST(RoundResult, TheTextLiesWithinHalfAUnitOfTheValue) {
  for (const double value : {1.0, -7.3e-5, 19.999854078, 123456.789}) {
    for (const double u : {1.23e-9, 4.5e-6, 0.0999, 0.015, 7.7, 88.0}) {
      const RoundedResult r = RoundResult(value, u);
      EXPECT_LE(std::fabs(r.value - value), r.HalfUnit() * (1 + 1e-9)) << value << " " << u;
      EXPECT_LE(std::fabs(r.uncertainty - u), r.HalfUnit() * (1 + 1e-9)) << value << " " << u;
      EXPECT_LT(std::fabs(r.uncertainty - u), 0.05 * u) << value << " " << u;  // two digits: under 5 %
    }
  }
}

TEST(SignificantText, TwoDigitsInFixedNotation) {
  EXPECT_EQ(SignificantText(0.0041666), "0.0042");
  EXPECT_EQ(SignificantText(-3.5), "-3.5");
  EXPECT_EQ(SignificantText(1234.0), "1200");
  EXPECT_EQ(SignificantText(0.0996), "0.10");
  EXPECT_EQ(SignificantText(208.8259), "210");
  EXPECT_EQ(SignificantText(0.0), "0");
  EXPECT_EQ(SignificantText(std::nan("")), "-");
  EXPECT_EQ(SignificantText(0.123456, 3), "0.123");
}

}  // namespace
}  // namespace sph::gum
