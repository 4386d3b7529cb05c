// An ISO 230-2 positioning-error table (actual minus target) imported as the Theta encoder term
// and used to compensate readings that the simulator made with that error, from its own physics.
#include "sph/model/iso230.hpp"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "sph/simulation/simulate.hpp"
#include "sph/model/compensation.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

// The Theta axis' deviation as a vendor's table gives it [arcsec]: 6 cos 2x - 4 sin 3x + 1.5 cos 5x.
double DeviationArcsec(double x_rad) {
  return 6.0 * std::cos(2 * x_rad) - 4.0 * std::sin(3 * x_rad) + 1.5 * std::cos(5 * x_rad);
}

std::vector<PositionalDeviation> Table(double sign) {
  std::vector<PositionalDeviation> table;
  for (int i = 0; i < 36; ++i) {
    const double target_deg = 10.0 * i;
    table.push_back({target_deg, sign * DeviationArcsec(target_deg * kRadPerDeg)});
  }
  return table;
}

TEST(ImportPositionalDeviations, TakesTheHarmonicsOfTheTableWithItsSign) {
  ImportedEncoderTerm imported;
  ASSERT_TRUE(ImportPositionalDeviations(Effect::kThetaEncoder, Table(1.0), 6, &imported));
  ASSERT_EQ(imported.term.size(), 12);
  EXPECT_EQ(imported.term.ParamName(2), "theta_encoder.c2");
  EXPECT_NEAR(imported.values[2], 6.0 * kRadPerArcsec, 1e-15);   // c2
  EXPECT_NEAR(imported.values[5], -4.0 * kRadPerArcsec, 1e-15);  // s3
  EXPECT_NEAR(imported.values[8], 1.5 * kRadPerArcsec, 1e-15);   // c5
  EXPECT_NEAR(imported.values[0], 0.0, 1e-15);
  EXPECT_NEAR(imported.mean_arcsec, 0.0, 1e-12);
  EXPECT_LT(imported.rms_residual_arcsec, 1e-12);
  // Too few rows for the harmonics asked, or no encoder: refused.
  EXPECT_FALSE(ImportPositionalDeviations(Effect::kThetaEncoder, Table(1.0), 17, &imported));
  EXPECT_FALSE(ImportPositionalDeviations(Effect::kProbeGain, Table(1.0), 2, &imported));
}

// The simulator turns the sphere to theta_read + deviation (the actual position); compensated with
// the imported table the points lie on the sphere to rounding; with the table in the VIM's sign
// (indicated minus true) unflipped, they are twice as far off as without any compensation.
TEST(ImportPositionalDeviations, CompensatesReadingsOfAMachineWithThatError) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.truth = ScmsGeometry{};
  const Eigen::Vector3d center(2.0, 0.0, 0.0);
  spec.centers_mm = {center};
  EffectTerm truth{Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}, {5, 0, false}}};
  spec.effects.model.terms = {truth};
  spec.effects.values = {{6.0 * kRadPerArcsec, -4.0 * kRadPerArcsec, 1.5 * kRadPerArcsec}};
  const PointsData points = Simulate(spec);
  auto worst_um = [&](double table_sign, bool compensate) {
    Calibration cal;
    cal.probe_offset_mm = spec.probe_offset_mm;
    if (compensate) {
      ImportedEncoderTerm imported;
      EXPECT_TRUE(ImportPositionalDeviations(Effect::kThetaEncoder, Table(table_sign), 6, &imported));
      cal.effects.terms = {imported.term};
      cal.effect_values = {imported.values};
    }
    double worst = 0.0;
    for (const Eigen::Vector3d& p : CompensateAll(cal, points.samples)) {
      worst = std::max(worst, std::abs((p - center).norm() - spec.sphere_radius_mm));
    }
    return worst * kUmPerMm;
  };
  const double none = worst_um(1.0, false);
  EXPECT_GT(none, 0.05);  // about e * 10 arcsec: 0.1 um at 2 mm
  EXPECT_LT(worst_um(1.0, true), 1e-9);
  EXPECT_NEAR(worst_um(-1.0, true), 2.0 * none, 0.02 * none);
}

}  // namespace
}  // namespace sph
