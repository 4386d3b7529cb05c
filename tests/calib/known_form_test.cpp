// The reference sphere's form as known in a one-placement calibration: from the file of a run
// that separated it (a prior on its coefficients with their covariance), or bounded by its
// certificate (sph/calib/known_form.hpp).
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/core/error.hpp"
#include "sph/io/html_report.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"
#include "sph/simulation/simulate.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

// The sphere's true form [um]: 0.043 um RMS over the sphere.
const std::vector<FormComponent> kForm = {{2, 0, 0.08}, {3, 1, 0.05}, {4, -2, 0.04}};

// kForm's RMS over the sphere [um]: sqrt(sum c^2 / (2l + 1)).
const double kFormRmsUm = std::sqrt(0.08 * 0.08 / 5 + 0.05 * 0.05 / 7 + 0.04 * 0.04 / 9);

// A calibration file holding the form of kForm on degrees 2..4 as a separation would give it:
// every coefficient with a standard uncertainty of `std_um`, uncorrelated but for two.
std::string FormFile(const std::string& dir, double std_um, double radius_mm = 20.0,
                     const std::vector<FormComponent>& form = kForm, const std::string& name = "separated.json") {
  CalibrationFile cal;
  cal.probe_offset_mm = 25.0;
  cal.sphere_radius_mm = radius_mm;
  cal.form_terms = FormTermsOfDegrees(2, 4);
  for (const FormTerm& t : cal.form_terms) {
    double v = 0.0;
    for (const FormComponent& c : form) v += c.l == t.l && c.m == t.m ? c.amplitude_um : 0.0;
    cal.form_values_mm.push_back(v * kMmPerUm);
    cal.form_std_mm.push_back(std_um * kMmPerUm);
  }
  const auto n = static_cast<Eigen::Index>(kNumScmsParams + cal.form_terms.size());
  Eigen::VectorXd sd = Eigen::VectorXd::Constant(n, std_um * kMmPerUm);
  sd.head<kNumScmsParams>() << 1e-6, 1e-4, 1e-6, 1e-4, 1e-6, 1e-4, 1e-4;
  Eigen::MatrixXd corr = Eigen::MatrixXd::Identity(n, n);
  corr(7, 8) = corr(8, 7) = 0.3;
  cal.parameter_covariance = sd.asDiagonal() * corr * sd.asDiagonal();
  cal.covariance = cal.parameter_covariance.topLeftCorner<kNumScmsParams, kNumScmsParams>();
  const std::string path = dir + "/" + name;
  WriteCalibrationFile(path, cal);
  return path;
}

// One placement of the sphere with kForm and a probe drift of 0.4 um, the sphere turned on its
// mount by `turn_deg` about the Theta axis (stated in the header when `stated`).
PointsData Daily(std::uint64_t seed, double turn_deg = 0.0, bool stated = true, double form_scale = 1.0) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = 0.03;
  spec.effects.form = kForm;
  for (FormComponent& c : spec.effects.form) c.amplitude_um *= form_scale;
  spec.effects.model.terms = {{Effect::kProbeDrift, {{1, 0, false}}}};
  spec.effects.values = {{0.4 * kMmPerUm}};
  if (turn_deg != 0.0) spec.mount_rotations_deg[0] = Eigen::Vector3d(0, 0, turn_deg);
  PointsData points = Simulate(spec);
  if (!stated) points.header.mount_rotations.clear();
  return points;
}

// One placement of the sphere with kForm and a cubic probe nonlinearity of 0.15 um.
PointsData DailyNonlinear(std::uint64_t seed) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = 0.03;
  spec.effects.form = kForm;
  spec.effects.model.terms = {{Effect::kProbeNonlinearity, {{3, 0, false}}}};
  spec.effects.values = {{0.15 * kMmPerUm}};
  return Simulate(spec);
}

// One placement of the sphere with kForm and a Phi encoder error of 10 arcsec (its c1).
PointsData DailyPhiEncoder(std::uint64_t seed) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = 0.03;
  spec.effects.form = kForm;
  spec.effects.model.terms = {{Effect::kPhiEncoder, {{1, 0, false}}}};
  spec.effects.values = {{10.0 * kRadPerArcsec}};
  return Simulate(spec);
}

CalibrationWorkflowOptions Options(const std::string& form_path) {
  CalibrationWorkflowOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  if (!form_path.empty()) o.sphere_form_paths.push_back(form_path);
  return o;
}

bool Added(const CalibrationWorkflowResult& run, Effect e) {
  return run.trace && run.trace->after.fit.model.Find(e) >= 0;
}

// Another sphere's form [um], 0.029 um RMS over the sphere.
const std::vector<FormComponent> kOtherForm = {{2, 1, 0.05}, {3, -2, 0.04}, {4, 3, 0.03}};

// One placement on the reference sphere (kForm) and one on another sphere of radius 15 mm with
// `form` (the simulator's other spheres are perfect: that setup's readings are simulated apart,
// the machine the same, and put in its place), noise 0.03 um.
PointsData TwoSpheres(std::uint64_t seed, const std::vector<FormComponent>& form) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = 0.03;
  spec.effects.form = kForm;
  spec.centers_mm.assign(2, Eigen::Vector3d(2, 0, 0));
  spec.sphere_radii_mm[1] = 15.0;
  PointsData points = Simulate(spec);
  SimulationSpec other;
  other.seed = seed + 1000;
  other.noise_r_um = 0.03;
  other.sphere_radius_mm = 15.0;
  other.effects.form = form;
  const PointsData second = Simulate(other);
  std::size_t next = 0;
  for (Sample& s : points.samples) {
    if (s.setup != 1) continue;
    static_cast<RawReading&>(s) = second.samples.at(next++);
  }
  EXPECT_EQ(next, second.samples.size());
  return points;
}

// The certificate's bound spread over degrees 2..L with the same variance v = rms^2 / (L - 1) for
// every coefficient: the expected mean square of the form over the sphere, sum v <S_lm^2>, is the
// bound's square. <S_lm^2> here by quadrature (equal-area bands of cos(polar) times longitudes),
// not by the 1 / (2l + 1) the prior's formula uses.
TEST(KnownForm, TheCertificatesBoundIsTheExpectedRmsOverTheSphere) {
  const double rms_mm = 0.05 * kMmPerUm;
  constexpr int kBands = 400, kLongitudes = 800;
  for (const int l_max : {2, 4, 8}) {
    const FormPrior prior = CertificateFormPrior(rms_mm, l_max);
    ASSERT_EQ(prior.terms.size(), static_cast<std::size_t>((l_max + 1) * (l_max + 1) - 4));
    EXPECT_EQ(prior.mean_mm.norm(), 0.0);
    double expected_ms = 0.0;  // sum over the coefficients of v <S^2>
    std::vector<double> mean_square(prior.terms.size(), 0.0);
    std::vector<double> s;
    for (int b = 0; b < kBands; ++b) {
      const double z = -1.0 + (2.0 * b + 1.0) / kBands;
      const double rho = std::sqrt(1.0 - z * z);
      for (int k = 0; k < kLongitudes; ++k) {
        const double lon = 2.0 * kPi * (k + 0.5) / kLongitudes;
        SchmidtHarmonicsOf(rho * std::cos(lon), rho * std::sin(lon), z, l_max, &s);
        for (std::size_t i = 0; i < prior.terms.size(); ++i) {
          const double v = s[HarmonicIndex(prior.terms[i].l, prior.terms[i].m)];
          mean_square[i] += v * v / (kBands * kLongitudes);
        }
      }
    }
    for (std::size_t i = 0; i < prior.terms.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      EXPECT_NEAR(mean_square[i], 1.0 / (2.0 * prior.terms[i].l + 1.0), 1e-4) << "l_max " << l_max << " term " << i;
      expected_ms += prior.covariance_mm2(k, k) * mean_square[i];
      EXPECT_DOUBLE_EQ(prior.covariance_mm2(k, k), rms_mm * rms_mm / (l_max - 1));
    }
    EXPECT_NEAR(std::sqrt(expected_ms) / rms_mm, 1.0, 1e-4) << "l_max " << l_max;
  }
}

// A probe drift in one placement with the sphere's form: with the form unknown a function of the
// direction explains it as well and nothing is added; with the form known from its separation the
// drift is found, near its true size, and the readings agree with the form.
TEST(KnownForm, FindsADriftInOnePlacementThatAnUnknownFormHides) {
  const std::string dir = sph::testing::MakeTempDir("known_form_drift");
  const std::string form = FormFile(dir, 0.002);
  const PointsData points = Daily(1);
  const CalibrationWorkflowResult without = RunCalibrationWorkflow(points, "daily", Options(""));
  EXPECT_FALSE(Added(without, Effect::kProbeDrift));
  EXPECT_FALSE(without.known_form.has_value());
  const CalibrationWorkflowResult with = RunCalibrationWorkflow(points, "daily", Options(form));
  ASSERT_TRUE(Added(with, Effect::kProbeDrift));
  ASSERT_TRUE(with.trace->form.known);
  const EffectFit& fit = with.trace->after.fit;
  const int drift = fit.model.Find(Effect::kProbeDrift);
  EXPECT_NEAR(fit.values[static_cast<std::size_t>(drift)][0] * kUmPerMm, 0.4,
              4.0 * fit.calibration.analysis.std(fit.TermOffset(static_cast<std::size_t>(drift))) * kUmPerMm);
  ASSERT_TRUE(with.known_form.has_value());
  const KnownFormCheck& k = *with.known_form;
  EXPECT_TRUE(k.agrees) << k.verdict;
  EXPECT_EQ(k.terms, 21);
  EXPECT_NEAR(k.known_rms_um, 0.0426, 5e-4);
  EXPECT_GT(k.explained_rms_um, 0.02);  // most of the form's 0.043 um RMS
  EXPECT_LT(k.rms_with_um, k.rms_without_um);
  EXPECT_TRUE(k.warnings.empty());
  // In both reports.
  EXPECT_THAT(with.JsonReport(), HasSubstr("\"known_form\""));
  std::ostringstream text;
  with.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr("known sphere form (" + form + ")"));
}

// The sphere turned by 90 deg about Theta: stated in the header, the known form is seen through
// that rotation and agrees, the drift is found. Not stated (the reference orientation assumed), the
// trace takes up the misfit with four effects of the Phi axis and the drift, beside which the test
// would not see it; the turn by right angles that fits the readings clearly better (by 90 deg about
// Theta) finds only the drift, and with that effect the readings reject the form as stated: the
// calibration is not usable, the trace adds nothing on top of it, and the orientation the readings
// support is named.
TEST(KnownForm, AWrongOrientationIsRejectedAndTheRightOneNamed) {
  const std::string dir = sph::testing::MakeTempDir("known_form_turned");
  const std::string form = FormFile(dir, 0.002);
  const CalibrationWorkflowResult right = RunCalibrationWorkflow(Daily(2, 90.0, true), "daily", Options(form));
  ASSERT_TRUE(right.known_form.has_value());
  EXPECT_TRUE(right.known_form->agrees) << right.known_form->verdict;
  EXPECT_TRUE(Added(right, Effect::kProbeDrift));
  EXPECT_TRUE(right.usability.usable) << (right.usability.reasons.empty() ? "" : right.usability.reasons[0]);
  const CalibrationWorkflowResult wrong = RunCalibrationWorkflow(Daily(2, 90.0, false), "daily", Options(form));
  ASSERT_TRUE(wrong.known_form.has_value());
  EXPECT_FALSE(wrong.known_form->agrees) << wrong.known_form->verdict;
  EXPECT_LT(wrong.known_form->conflict_p_value, kStatementP);
  ASSERT_EQ(wrong.statements.size(), 1u);
  const StatementCheck& s = wrong.statements[0];
  EXPECT_EQ(s.kind, StatementKind::kKnownForm);
  EXPECT_TRUE(s.rejected);
  EXPECT_GT(s.dof, 0);
  EXPECT_THAT(s.statement, HasSubstr("--sphere-form " + form + " at setup 0 in the reference orientation"));
  ASSERT_TRUE(s.orientation.has_value());
  EXPECT_TRUE(s.orientation->agrees) << s.orientation->text;
  EXPECT_LT((s.orientation->right_angle_deg - Eigen::Vector3d(0, 0, 90)).norm(), 1e-6) << s.orientation->text;
  EXPECT_THAT(s.orientation->text, HasSubstr("the readings fit the known form turned 0 0 90 ("));
  // Not usable, the reason naming the statement and both values; nothing added on top of it.
  EXPECT_FALSE(wrong.usability.usable);
  ASSERT_FALSE(wrong.usability.reasons.empty());
  EXPECT_THAT(wrong.usability.reasons[0], HasSubstr("the readings reject --sphere-form " + form));
  EXPECT_THAT(wrong.usability.reasons[0], HasSubstr("stated a form of RMS 0.0426 um over the sphere"));
  EXPECT_THAT(wrong.usability.reasons[0], HasSubstr("the readings without it a form that differs from it by "));
  ASSERT_TRUE(wrong.trace.has_value());
  EXPECT_TRUE(wrong.trace->added.empty());
  EXPECT_FALSE(wrong.withheld.empty());
  // Among the warnings of the run and of the JSON report, whose "statements" carry the test.
  bool warned = false;
  for (const std::string& w : wrong.warnings) warned |= w.find("the readings reject the known form") == 0;
  EXPECT_TRUE(warned);
  const nlohmann::json j = nlohmann::json::parse(wrong.JsonReport());
  bool in_json = false;
  for (const auto& w : j.at("warnings")) in_json |= w.get<std::string>().find("the readings reject") == 0;
  EXPECT_TRUE(in_json);
  EXPECT_FALSE(j.at("usable").get<bool>());
  EXPECT_TRUE(j.at("statements").at("tests").at(0).at("rejected").get<bool>());
  EXPECT_NEAR(
      j.at("statements").at("tests").at(0).at("supported_orientation").at("right_angle_deg").at(2).get<double>(), 90.0,
      1e-9);
  EXPECT_THROW(wrong.MakeCalibrationFile(), Error);
}

// The right orientation stated beside a real drift of 0.4 um: the form as known, judged on the
// seven errors alone, fits the readings worse than none (the drift dominates both fits), but the
// test is the readings' own estimate with the drift the trace found kept: not rejected, usable.
TEST(KnownForm, TheRightOrientationBesideARealDriftIsNotRejected) {
  const std::string dir = sph::testing::MakeTempDir("known_form_right_drift");
  const std::string form = FormFile(dir, 0.002);
  for (const std::uint64_t seed : {3, 4, 5}) {
    const CalibrationWorkflowResult run = RunCalibrationWorkflow(Daily(seed), "daily", Options(form));
    ASSERT_TRUE(run.known_form.has_value());
    EXPECT_TRUE(run.known_form->agrees) << "seed " << seed << ": " << run.known_form->verdict;
    EXPECT_TRUE(run.usability.usable) << "seed " << seed;
    bool warned = false;
    for (const std::string& w : run.warnings) warned |= w.find("known form") != std::string::npos;
    EXPECT_FALSE(warned) << "seed " << seed;
  }
}

// A certificate's bound ten times too tight: the example's one-placement sphere has a form of
// 0.047 um RMS, the bound states 0.005 um. The readings reject the bound as a prior (a form of
// several times it in the directions they determine), the calibration is not usable, and the
// effects the trace found beside the bound (they took up the form it held small) are not applied.
TEST(KnownForm, ABoundTooTightForTheExampleSphereIsRejected) {
  CalibrationWorkflowOptions o;
  o.conditions.sphere_form_rms_um = 0.005;
  const CalibrationWorkflowResult run =
      RunCalibrationWorkflow(SPH_SOURCE_DIR "/data/example/separation/one_placement.txt", o);
  ASSERT_TRUE(run.known_form.has_value());
  EXPECT_TRUE(run.known_form->exceeds_bound) << run.known_form->verdict;
  EXPECT_GT(run.known_form->conflict_dof, 0);
  ASSERT_EQ(run.statements.size(), 1u);
  EXPECT_EQ(run.statements[0].kind, StatementKind::kFormBound);
  EXPECT_EQ(run.statements[0].statement, "--sphere-form-rms-um 0.005");
  EXPECT_TRUE(run.statements[0].rejected);
  EXPECT_FALSE(run.usability.usable);
  ASSERT_TRUE(run.trace.has_value());
  EXPECT_TRUE(run.trace->added.empty());
  EXPECT_FALSE(run.withheld.empty());
}

// A cubic probe nonlinearity in one placement: a power of the reading is then a form of low
// degree, so beside a free form nothing tells them apart; with the form known within its
// covariance the nonlinearity is separable (its u^3 alone beside the seven errors, the centre and
// the known form: variance inflation about 7), and it is what is found, not an encoder error or a
// spindle motion taking its signal.
TEST(KnownForm, FindsAProbeNonlinearityInOnePlacementNotAnotherEffect) {
  const std::string dir = sph::testing::MakeTempDir("known_form_nonlinear");
  const CalibrationWorkflowResult with = RunCalibrationWorkflow(DailyNonlinear(1), "daily", Options(FormFile(dir, 0.002)));
  ASSERT_TRUE(with.trace.has_value());
  ASSERT_EQ(with.trace->added.size(), 1u) << "added " << with.trace->added.size() << " effects";
  EXPECT_EQ(with.trace->added[0], Effect::kProbeNonlinearity) << InfoOf(with.trace->added[0]).id;
}

// The prior decides as much as it knows: with the covariance 100 times larger (std 10 times), the
// form is nearly free again and the drift is not found.
TEST(KnownForm, AnUncertainFormDecidesNothing) {
  const std::string dir = sph::testing::MakeTempDir("known_form_loose");
  const CalibrationWorkflowResult loose = RunCalibrationWorkflow(Daily(1), "daily", Options(FormFile(dir, 0.2)));
  EXPECT_FALSE(Added(loose, Effect::kProbeDrift));
}

// What a loose prior leaves to the readings, they decide: one placement tells a Phi encoder error
// from any form of the known degrees by itself (its c1 beside the seven errors, the centre and a
// free form of degrees 2..4 has a variance inflation below 100), so with the form's covariance 100
// times that of a separation it is still found, and nothing else is added.
TEST(KnownForm, AnUncertainFormLeavesAPhiEncoderErrorToTheReadings) {
  const PointsData points = DailyPhiEncoder(1);
  CalibrationOptions free_form;
  free_form.sphere_radius_mm = 20.0;
  free_form.probe_offset_mm = 25.0;
  EffectModel model;
  model.reference = EffectReferenceOf(points.samples);
  model.terms = {{Effect::kPhiEncoder, {{1, 0, false}}}};
  model.form = FormModelOf(points, FormTermsOfDegrees(2, 4));
  const EffectFit fit =
      FitEffects(points, free_form, model, EffectFitStart::From(Calibrate(points, free_form)));
  EXPECT_LT(fit.calibration.analysis.vif(fit.TermOffset(0)), 100.0);

  const std::string dir = sph::testing::MakeTempDir("known_form_loose_phi");
  const CalibrationWorkflowResult loose = RunCalibrationWorkflow(points, "daily", Options(FormFile(dir, 0.02)));
  ASSERT_TRUE(loose.trace.has_value());
  ASSERT_EQ(loose.trace->added.size(), 1u);
  ASSERT_EQ(loose.trace->added[0], Effect::kPhiEncoder);
}

// The certificate's bound alone, on a design whose readings determine the form (the sphere in
// three known orientations): a form of 0.043 um RMS against a bound of 0.005 um pulls the fitted
// form beyond it, and it is reported as such. (In one placement the readings barely pull the form
// away from a tight bound: its prior then holds it, and the report shows what the fit says.)
TEST(KnownForm, AFormLargerThanTheCertificatesBoundIsReported) {
  SimulationSpec spec;
  spec.seed = 3;
  spec.noise_r_um = 0.03;
  spec.effects.form = kForm;
  spec.centers_mm.assign(3, Eigen::Vector3d(2, 0, 0));
  spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {90, 0, 0}}};
  CalibrationWorkflowOptions o = Options("");
  o.conditions.sphere_form_rms_um = 0.005;
  o.trace_options.form_degree_max = 4;  // the bound over degrees 2..4, kForm's: a quicker trace
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(Simulate(spec), "three", o);
  ASSERT_TRUE(run.known_form.has_value());
  EXPECT_EQ(run.known_form->source, "the certificate's bound");
  ASSERT_TRUE(run.known_form->bound_rms_um.has_value());
  EXPECT_GT(run.known_form->fitted_rms_um, 0.005) << run.known_form->verdict;
  bool larger = false;
  for (const std::string& w : run.known_form->warnings) {
    larger |= w.find("larger than the certificate's bound") != std::string::npos;
  }
  EXPECT_TRUE(larger);
}

// A certificate's bound too tight, in one placement: a form of 3 times the bound is held small by
// the prior and the residual takes the rest; the readings reject the bound as a prior, and the
// report says the sphere's form exceeds it (text, JSON).
TEST(KnownForm, AFormBeyondItsCertificatesBoundInOnePlacementIsReported) {
  CalibrationWorkflowOptions o = Options("");
  o.conditions.sphere_form_rms_um = kFormRmsUm / 3.0;
  o.trace_options.form_degree_max = 4;  // the bound over degrees 2..4, kForm's: a quicker trace
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(Daily(1), "daily", o);
  ASSERT_TRUE(run.known_form.has_value());
  const KnownFormCheck& k = *run.known_form;
  EXPECT_TRUE(k.exceeds_bound) << k.verdict;
  EXPECT_FALSE(k.agrees);
  EXPECT_LT(k.conflict_p_value, kKnownFormP);
  bool said = false;
  for (const std::string& w : run.warnings) said |= w.find("the sphere's form exceeds its certificate's bound") == 0;
  EXPECT_TRUE(said);
  EXPECT_TRUE(nlohmann::json::parse(run.JsonReport()).at("known_form").at("exceeds_bound").get<bool>());
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr(": the sphere's form exceeds its certificate's bound\n"));
}

// No false report: a form within its bound (the bound 1.5 times its RMS), a few seeds.
TEST(KnownForm, AFormWithinItsCertificatesBoundIsNotReported) {
  CalibrationWorkflowOptions o = Options("");
  o.conditions.sphere_form_rms_um = 1.5 * kFormRmsUm;
  o.trace_options.form_degree_max = 4;
  for (const std::uint64_t seed : {1, 2, 3, 4}) {
    const CalibrationWorkflowResult run = RunCalibrationWorkflow(Daily(seed), "daily", o);
    ASSERT_TRUE(run.known_form.has_value());
    const KnownFormCheck& k = *run.known_form;
    EXPECT_GT(k.conflict_dof, 0) << "seed " << seed;
    EXPECT_FALSE(k.exceeds_bound) << "seed " << seed << ": " << k.verdict;
  }
}

// Both given: the known form is the prior and the certificate is checked against it.
TEST(KnownForm, TheCertificateIsCheckedAgainstTheKnownForm) {
  const std::string dir = sph::testing::MakeTempDir("known_form_both");
  CalibrationWorkflowOptions o = Options(FormFile(dir, 0.002));
  o.conditions.sphere_form_rms_um = 0.02;  // the known form has 0.043 um RMS
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(Daily(1), "daily", o);
  ASSERT_TRUE(run.known_form.has_value());
  EXPECT_EQ(run.known_form->terms, 21);  // the file's terms, not the bound's
  bool exceeds = false;
  for (const std::string& w : run.known_form->warnings)
    exceeds |= w.find("exceeds the certificate's bound") != std::string::npos;
  EXPECT_TRUE(exceeds);
  // The HTML report's section holds the JSON's numbers, its verdict and its warnings.
  const nlohmann::json k = nlohmann::json::parse(run.JsonReport()).at("known_form");
  const std::string page = run.HtmlReport();
  const auto has = [&](const std::string& text) { return page.find(text) != std::string::npos; };
  EXPECT_TRUE(has("<h2>" + html::Escape("The sphere's known form") + "</h2>"));
  for (const char* key :
       {"known_rms_um", "fitted_rms_um", "explained_rms_um", "rms_with_um", "rms_without_um", "chi_square", "p_value",
        "bound_rms_um", "terms", "conflict_chi_square", "conflict_degrees_of_freedom", "conflict_p_value"}) {
    EXPECT_TRUE(has(">" + html::Number(k.at(key).get<double>()) + "</td>")) << key;
  }
  EXPECT_TRUE(has(html::Escape(k.at("verdict").get<std::string>())));
  ASSERT_FALSE(k.at("warnings").empty());
  for (const nlohmann::json& w : k.at("warnings")) EXPECT_TRUE(has(html::Escape(w.get<std::string>()))) << w;
}

// A second sphere's known form (sphere_radius_mm@1): each file matched to its sphere by its R0
// (the files in either order), the second sphere's form a prior on its own set, checked and reported
// like the reference sphere's; a file of another form for it is reported as disagreeing.
TEST(KnownForm, ASecondSpheresKnownFormIsCheckedAndReportedLikeTheReferences) {
  const std::string dir = sph::testing::MakeTempDir("known_form_second");
  const std::string reference = FormFile(dir, 0.002);
  const std::string second = FormFile(dir, 0.002, 15.0, kOtherForm, "second.json");
  CalibrationWorkflowOptions o = Options("");
  o.sphere_form_paths = {second, reference};
  o.trace_options.candidates = {Effect::kProbeDrift};  // a quicker trace: the forms are what is checked
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(TwoSpheres(5, kOtherForm), "two", o);
  ASSERT_TRUE(run.known_form.has_value());
  EXPECT_EQ(run.known_form->source, reference);
  EXPECT_TRUE(run.known_form->agrees) << run.known_form->verdict;
  ASSERT_EQ(run.other_known_forms.size(), 1u);
  const KnownFormCheck& k = run.other_known_forms[0];
  EXPECT_EQ(k.source, second);
  EXPECT_EQ(k.setups, std::vector<int>{1});
  EXPECT_EQ(k.terms, 21);
  EXPECT_TRUE(k.agrees) << k.verdict;
  EXPECT_NEAR(k.known_rms_um, 0.0288, 5e-4);
  EXPECT_NEAR(k.fitted_rms_um, k.known_rms_um, 0.003);
  EXPECT_LT(k.rms_with_um, k.rms_without_um);  // the second sphere's form explains its readings
  const nlohmann::json j = nlohmann::json::parse(run.JsonReport());
  ASSERT_EQ(j.at("known_forms_of_other_spheres").size(), 1u);
  EXPECT_EQ(j.at("known_forms_of_other_spheres")[0].at("setups"), nlohmann::json::array({1}));
  EXPECT_DOUBLE_EQ(j.at("known_forms_of_other_spheres")[0].at("rms_with_um").get<double>(), k.rms_with_um);
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr("known sphere form of the sphere of setups 1 (" + second + ")"));
  EXPECT_NE(run.HtmlReport().find("The known form of the sphere of setups 1"), std::string::npos);
  // The second sphere is not the one its file holds: its readings disagree with it.
  const CalibrationWorkflowResult wrong = RunCalibrationWorkflow(TwoSpheres(5, kForm), "two", o);
  ASSERT_EQ(wrong.other_known_forms.size(), 1u);
  EXPECT_FALSE(wrong.other_known_forms[0].agrees) << wrong.other_known_forms[0].verdict;
  EXPECT_FALSE(wrong.other_known_forms[0].warnings.empty());
}

// A file is matched to the one sphere whose radius is its R0: a file of none, two files of one
// sphere, or another sphere's form alone are refused (a file of either of two spheres: the apps'
// bad-input matrix).
TEST(KnownForm, AFileOfNoSphereOrOfTwoOrTwoFilesOfOneAreRefused) {
  const std::string dir = sph::testing::MakeTempDir("known_form_match");
  const std::string reference = FormFile(dir, 0.002);
  const std::string second = FormFile(dir, 0.002, 15.0, kOtherForm, "second.json");
  const PointsData points = TwoSpheres(5, kOtherForm);
  const auto refused = [&](const std::vector<std::string>& files, const std::string& message) {
    CalibrationWorkflowOptions o = Options("");
    o.sphere_form_paths = files;
    try {
      RunCalibrationWorkflow(points, "two", o);
      ADD_FAILURE() << "no error for " << message;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(message));
    }
  };
  refused({FormFile(dir, 0.002, 12.0, kOtherForm, "none.json")},
          "is none of the spheres of two (R0 20 mm (u 0 um), sphere_radius_mm@1 15 mm (u 0 um))");
  refused({reference, FormFile(dir, 0.002, 20.0, kForm, "again.json")}, "both hold a form of the sphere R0");
  refused({second}, "needs the reference sphere's form known too");
}

// The form belongs to its sphere: another R0 beyond both uncertainties is refused with both values.
TEST(KnownForm, AnotherSpheresRadiusIsRefused) {
  const std::string dir = sph::testing::MakeTempDir("known_form_radius");
  const std::string form = FormFile(dir, 0.002, 20.001);
  try {
    RunCalibrationWorkflow(Daily(1), "daily", Options(form));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("sphere_radius_mm 20 mm"));
    EXPECT_THAT(e.what(), HasSubstr("20.001 mm"));
  }
  CalibrationWorkflowOptions within = Options(form);
  within.conditions.sphere_radius_u_um = 1.0;  // 1 um apart, within u
  EXPECT_NO_THROW(RunCalibrationWorkflow(Daily(1), "daily", within));
}

}  // namespace
}  // namespace sph
