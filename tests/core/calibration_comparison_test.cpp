#include "sph/io/calibration_comparison.hpp"

#include <cmath>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

// A calibration of the seven errors with a diagonal covariance: std 1 urad for the angles, 0.1 um
// for the lengths, and an R0 input of u = 0.05 um acting on d' alone (one to one).
CalibrationFile SevenErrors() {
  CalibrationFile f;
  f.geometry = {1e-4, 0.002, -2e-4, 0.001, 3e-4, -0.0015, -0.05};
  f.probe_offset_mm = 25.0;
  f.sphere_radius_mm = 12.5;
  Eigen::Matrix<double, 7, 7> c = Eigen::Matrix<double, 7, 7>::Zero();
  for (int p = 0; p < kNumScmsParams; ++p) {
    const double u = kScmsParamInfo[static_cast<std::size_t>(p)].quantity == Quantity::kAngle ? 1e-6 : 1e-4;
    c(p, p) = u * u;
  }
  CalibrationFile::CovarianceInput r0{"R0 (certificate)", "um", 0.05, Eigen::VectorXd::Zero(7)};
  r0.per_unit(kDPrime) = -kMmPerUm;  // d' moves against R0, one to one
  c(kDPrime, kDPrime) += std::pow(0.05 * kMmPerUm, 2);
  f.covariance = c;
  f.covariance_inputs.push_back(r0);
  return f;
}

const ComparedParameter& Find(const CalibrationComparison& cmp, const std::string& name) {
  for (const ComparedParameter& c : cmp.parameters) {
    if (c.parameter == name) return c;
  }
  throw Error("no " + name);
}

TEST(CalibrationComparison, SameCalibrationIsUnchanged) {
  const CalibrationFile f = SevenErrors();
  const CalibrationComparison cmp = CompareCalibrations(f, f, "before.json");
  ASSERT_EQ(cmp.parameters.size(), 7u);
  for (const ComparedParameter& c : cmp.parameters) {
    EXPECT_EQ(c.found, ComparedParameter::Found::kBoth) << c.parameter;
    EXPECT_DOUBLE_EQ(c.difference, 0.0) << c.parameter;
    EXPECT_DOUBLE_EQ(c.En, 0.0) << c.parameter;
  }
  EXPECT_TRUE(cmp.Unchanged());
  EXPECT_THAT(cmp.verdict, HasSubstr("unchanged within uncertainty (7 parameters"));
}

TEST(CalibrationComparison, DifferenceUAndEnInReportUnits) {
  const CalibrationFile before = SevenErrors();
  CalibrationFile now = before;
  now.geometry[kAlpha] += 3e-6;    // 3 urad: U = 2 sqrt(2) urad
  now.geometry[kA] -= 0.1 * 1e-3;  // -0.1 um: U = 2 sqrt(2) 0.1 um
  const CalibrationComparison cmp = CompareCalibrations(before, now, "before.json");
  const ComparedParameter& alpha = Find(cmp, "alpha");
  EXPECT_EQ(alpha.unit, "urad");
  EXPECT_NEAR(alpha.previous, 100.0, 1e-9);
  EXPECT_NEAR(alpha.now, 103.0, 1e-9);
  EXPECT_NEAR(alpha.difference, 3.0, 1e-9);
  EXPECT_NEAR(alpha.U, 2.0 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(alpha.En, 3.0 / (2.0 * std::sqrt(2.0)), 1e-9);
  const ComparedParameter& a = Find(cmp, "a");
  EXPECT_EQ(a.unit, "um");
  EXPECT_NEAR(a.difference, -0.1, 1e-9);
  EXPECT_NEAR(a.U, 0.2 * std::sqrt(2.0), 1e-9);
  EXPECT_FALSE(cmp.Unchanged());
  EXPECT_THAT(cmp.verdict, HasSubstr("moved: alpha by +1.1 U (1 of 7 parameters compared"));
}

// The same certificate in both: its contribution cancels in d' (it acts alike), so U is the two
// fits' scatter alone; with another sphere's R0 it counts in each.
TEST(CalibrationComparison, SharedCertificateCancelsWhereItActsAlike) {
  const CalibrationFile before = SevenErrors();
  CalibrationFile now = before;
  const double u_a = 0.1, u_r0 = 0.05;  // um
  CalibrationComparison cmp = CompareCalibrations(before, now, "before.json");
  EXPECT_EQ(cmp.correlated_inputs, std::vector<std::string>{"R0 (certificate)"});
  EXPECT_NEAR(Find(cmp, "d_prime").U, 2.0 * std::sqrt(2.0) * u_a, 1e-9);
  now.sphere_radius_mm = 12.6;
  cmp = CompareCalibrations(before, now, "before.json");
  EXPECT_TRUE(cmp.correlated_inputs.empty());
  EXPECT_THAT(cmp.notes.front(), HasSubstr("another sphere or certificate, counted independent"));
  EXPECT_NEAR(Find(cmp, "d_prime").U, 2.0 * std::sqrt(2.0 * (u_a * u_a + u_r0 * u_r0)), 1e-9);
}

// An older file whose covariance does not itemise its inputs: the certificate is counted
// independent (U larger, never smaller), and said so; a file without a covariance gives no U.
TEST(CalibrationComparison, OlderFilesCountTheirInputsIndependentOrGiveNoU) {
  CalibrationFile before = SevenErrors();
  before.covariance_inputs.clear();
  const CalibrationFile now = SevenErrors();
  CalibrationComparison cmp = CompareCalibrations(before, now, "before.json");
  EXPECT_TRUE(cmp.correlated_inputs.empty());
  EXPECT_THAT(cmp.notes.front(), HasSubstr("R0 (certificate): not itemised in the previous calibration's covariance: "
                                           "counted independent"));
  const double u_a = 0.1, u_r0 = 0.05;  // um
  EXPECT_NEAR(Find(cmp, "d_prime").U, 2.0 * std::sqrt(2.0 * (u_a * u_a + u_r0 * u_r0)), 1e-9);
  before.covariance.reset();
  cmp = CompareCalibrations(before, now, "before.json");
  const ComparedParameter& d = Find(cmp, "d_prime");
  EXPECT_DOUBLE_EQ(d.difference, 0.0);
  EXPECT_TRUE(std::isnan(d.U));
  EXPECT_THAT(d.note, HasSubstr("no U: a calibration file states no covariance of it"));
  EXPECT_THAT(cmp.verdict, HasSubstr("nothing compared with an uncertainty"));
  EXPECT_FALSE(cmp.Unchanged());
  EXPECT_THAT(cmp.verdict, HasSubstr("not compared: alpha, a, beta, b, epsilon, c, d_prime"));
}

TEST(CalibrationComparison, EffectOfOneCalibrationOnlyListedWithItsValueAndU) {
  const CalibrationFile before = SevenErrors();
  CalibrationFile now = before;
  EffectTerm term{Effect::kThetaEncoder, {{2, 0, false}}};
  now.effects.terms.push_back(term);
  now.effect_values.push_back({2.0 * kRadPerArcsec});
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(8, 8);
  c.topLeftCorner<7, 7>() = *now.covariance;
  c(7, 7) = std::pow(0.25 * kRadPerArcsec, 2);
  now.parameter_covariance = c;
  now.covariance_inputs.front().per_unit.conservativeResize(8);
  now.covariance_inputs.front().per_unit(7) = 0.0;
  const CalibrationComparison cmp = CompareCalibrations(before, now, "before.json");
  const ComparedParameter& e = Find(cmp, "theta_encoder.c2");
  EXPECT_EQ(e.found, ComparedParameter::Found::kNowOnly);
  EXPECT_EQ(e.unit, "arcsec");
  EXPECT_NEAR(e.now, 2.0, 1e-9);
  EXPECT_TRUE(std::isnan(e.previous));
  EXPECT_NEAR(e.U, 0.5, 1e-9);
  EXPECT_TRUE(cmp.Unchanged());
  EXPECT_THAT(cmp.verdict, HasSubstr("found in one calibration only: theta_encoder.c2 (now only)"));
  EXPECT_THAT(cmp.verdict, HasSubstr("the two fits' models differ"));
  // The other way round.
  const CalibrationComparison back = CompareCalibrations(now, before, "now.json");
  EXPECT_EQ(Find(back, "theta_encoder.c2").found, ComparedParameter::Found::kPreviousOnly);
}

TEST(CalibrationComparison, ProbeTermsOfOtherReadingsAreNotCompared) {
  CalibrationFile before = SevenErrors();
  before.effects.terms.push_back(EffectTerm{Effect::kProbeGain, {{1, 0, false}}});
  before.effect_values.push_back({1e-4});
  before.effects.reference.r_ref_mm = 0.5;
  before.effects.reference.r_half_range_mm = 0.2;
  CalibrationFile now = before;
  now.effects.reference.r_ref_mm = 0.6;
  const CalibrationComparison cmp = CompareCalibrations(before, now, "before.json");
  const ComparedParameter& k = Find(cmp, "probe_gain.u1");
  EXPECT_FALSE(k.Compared());
  EXPECT_THAT(k.note, HasSubstr("normalised by other probe readings"));
  EXPECT_THAT(cmp.verdict, HasSubstr("not compared: probe_gain.u1"));
}

TEST(CalibrationComparison, FormRmsWhenBothHaveOne) {
  CalibrationFile before = SevenErrors();
  before.form_terms = {{2, 0}, {3, 1}};
  before.form_values_mm = {0.05e-3, 0.0};
  before.form_std_mm = {0.002e-3, 0.002e-3};
  CalibrationFile now = before;
  now.form_values_mm = {0.06e-3, 0.0};
  const CalibrationComparison cmp = CompareCalibrations(before, now, "before.json");
  const ComparedParameter& rms = Find(cmp, "sphere_form.rms");
  // rms = |c20| / sqrt(5); its u = u(c20) / sqrt(5) to first order.
  EXPECT_NEAR(rms.previous, 0.05 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(rms.difference, 0.01 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(rms.U, 2.0 * std::sqrt(2.0) * 0.002 / std::sqrt(5.0), 1e-12);
}

TEST(CalibrationComparison, RefusesAnotherNominalProbeOffset) {
  const CalibrationFile before = SevenErrors();
  CalibrationFile now = before;
  now.probe_offset_mm = 30.0;
  try {
    CompareCalibrations(before, now, "before.json");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("before.json: field 'probe_offset_mm' is 25 mm, this calibration's nominal d is "
                                    "30 mm"));
  }
}

}  // namespace
}  // namespace sph
