#include "sph/model/spherical_harmonics.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace sph {
namespace {

// Hand-worked Schmidt semi-normalised harmonics: S_20 = (3x^2 - 1) / 2, S_22 = sqrt(3)/2 (1 - x^2)
// cos 2 lon, S_3,-3 = sqrt(5/8) (1 - x^2)^(3/2) sin 3 lon.
TEST(SchmidtHarmonic, HandWorkedValues) {
  for (const double x : {-0.9, -0.2, 0.0, 0.4, 1.0}) {
    for (const double lon : {-2.0, 0.3, 1.7}) {
      EXPECT_NEAR(SchmidtHarmonic(2, 0, lon, x), (3 * x * x - 1) / 2, 1e-15);
      EXPECT_NEAR(SchmidtHarmonic(2, 2, lon, x), std::sqrt(3.0) / 2 * (1 - x * x) * std::cos(2 * lon), 1e-15);
      EXPECT_NEAR(SchmidtHarmonic(3, -3, lon, x), std::sqrt(5.0 / 8) * std::pow(1 - x * x, 1.5) * std::sin(3 * lon),
                  1e-15);
    }
  }
}

TEST(SchmidtHarmonics, AreTheSingleHarmonicsAllAtOnce) {
  SchmidtHarmonics all(2, 5);
  ASSERT_EQ(all.size(), 32);
  double values[32];
  for (const double x : {-1.0, -0.7, 0.05, 0.99}) {
    for (const double lon : {-3.1, -0.4, 0.0, 2.2}) {
      all.Evaluate(lon, x, values);
      int k = 0;
      for (int l = 2; l <= 5; ++l) {
        for (int m = -l; m <= l; ++m) {
          EXPECT_NEAR(values[k++], SchmidtHarmonic(l, m, lon, x), 1e-14) << "l " << l << " m " << m;
        }
      }
    }
  }
}

}  // namespace
}  // namespace sph
