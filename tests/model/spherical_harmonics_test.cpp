#include "sph/model/spherical_harmonics.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace sph {
namespace {

// An oracle of its own: P_l^m(x) by the textbook recurrence in the sine of the polar angle, and
// the longitude by cos and sin (what the Cartesian evaluation avoids).
double LegendreOracle(int l, int m, double x) {
  double pmm = 1.0;
  const double s = std::sqrt(std::max(0.0, 1.0 - x * x));
  for (int i = 1; i <= m; ++i) pmm *= (2.0 * i - 1.0) * s;
  if (l == m) return pmm;
  double pm1 = x * (2.0 * m + 1.0) * pmm;
  for (int ll = m + 2; ll <= l; ++ll) {
    const double pll = (x * (2.0 * ll - 1.0) * pm1 - (ll + m - 1.0) * pmm) / (ll - m);
    pmm = pm1;
    pm1 = pll;
  }
  return pm1;
}

double HarmonicOracle(int l, int m, double lon, double x) {
  const int am = std::abs(m);
  double ratio = 1.0;
  for (int i = l - am + 1; i <= l + am; ++i) ratio /= i;
  const double norm = am > 0 ? std::sqrt(2.0 * ratio) : 1.0;
  return norm * LegendreOracle(l, am, x) * (m >= 0 ? std::cos(am * lon) : std::sin(am * lon));
}

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

TEST(SchmidtHarmonicsOf, HandWorkedValues) {
  std::vector<double> s;
  // At the pole only the zonal terms are non-zero, and S_l0(1) = P_l(1) = 1.
  SchmidtHarmonicsOf(0.0, 0.0, 1.0, 6, &s);
  for (int l = 0; l <= 6; ++l) {
    for (int m = -l; m <= l; ++m) EXPECT_NEAR(s[HarmonicIndex(l, m)], m == 0 ? 1.0 : 0.0, 1e-15);
  }
  // On the equator at longitude 0: S_20 = P_2(0) = -1/2, S_22 = sqrt(2 / 4!) * 3 = sqrt(3)/2, S_2,-2 = 0.
  SchmidtHarmonicsOf(1.0, 0.0, 0.0, 2, &s);
  EXPECT_NEAR(s[HarmonicIndex(2, 0)], -0.5, 1e-15);
  EXPECT_NEAR(s[HarmonicIndex(2, 2)], std::sqrt(3.0) / 2.0, 1e-15);
  EXPECT_NEAR(s[HarmonicIndex(2, -2)], 0.0, 1e-15);
  // At longitude 45 deg on the equator S_2,-2 = sqrt(3)/2 sin(90 deg) and S_22 = sqrt(3)/2 cos(90 deg) = 0.
  SchmidtHarmonicsOf(std::sqrt(0.5), std::sqrt(0.5), 0.0, 2, &s);
  EXPECT_NEAR(s[HarmonicIndex(2, -2)], std::sqrt(3.0) / 2.0, 1e-15);
  EXPECT_NEAR(s[HarmonicIndex(2, 2)], 0.0, 1e-15);
}

// The Cartesian evaluation (function and class) equals the oracle, term by term, up to degree 12.
TEST(SchmidtHarmonics, EqualTheLongitudeLatitudeOracle) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n;
  SchmidtHarmonics all(2, 12);
  std::vector<double> s, values(static_cast<std::size_t>(all.size()));
  for (int k = 0; k < 200; ++k) {
    double x = n(rng), y = n(rng), z = n(rng);
    const double norm = std::sqrt(x * x + y * y + z * z);
    x /= norm, y /= norm, z /= norm;
    SchmidtHarmonicsOf(x, y, z, 12, &s);
    all.Evaluate(x, y, z, values.data());
    int j = 0;
    for (int l = 0; l <= 12; ++l) {
      for (int m = -l; m <= l; ++m) {
        const double oracle = HarmonicOracle(l, m, std::atan2(y, x), z);
        EXPECT_NEAR(s[HarmonicIndex(l, m)], oracle, 1e-12) << "l " << l << " m " << m;
        if (l >= 2) {
          EXPECT_NEAR(values[static_cast<std::size_t>(j++)], oracle, 1e-12) << "l " << l << " m " << m;
        }
      }
    }
  }
}

// The gradients on R^3 equal central differences of the polynomial extension, which the class
// evaluates off the unit sphere just as well.
TEST(SchmidtHarmonics, GradientMatchesCentralDifferences) {
  SchmidtHarmonics all(2, 8);
  const auto size = static_cast<std::size_t>(all.size());
  std::vector<double> values(size), gradient(3 * size), plus(size), minus(size);
  for (const auto& u : {std::array<double, 3>{0.6, -0.48, 0.64}, std::array<double, 3>{0.0, 0.0, 1.0},
                        std::array<double, 3>{-0.28, 0.96, 0.0}}) {
    all.Evaluate(u[0], u[1], u[2], values.data(), gradient.data());
    const double h = 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
      std::array<double, 3> a = u, b = u;
      a[static_cast<std::size_t>(axis)] += h;
      b[static_cast<std::size_t>(axis)] -= h;
      all.Evaluate(a[0], a[1], a[2], plus.data());
      all.Evaluate(b[0], b[1], b[2], minus.data());
      for (std::size_t k = 0; k < size; ++k) {
        EXPECT_NEAR(gradient[3 * k + static_cast<std::size_t>(axis)], (plus[k] - minus[k]) / (2 * h), 1e-6)
            << "function " << k << " axis " << axis;
      }
    }
  }
}

}  // namespace
}  // namespace sph
