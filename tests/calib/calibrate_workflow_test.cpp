#include "sph/calib/calibrate_workflow.hpp"

#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/calib/misreading.hpp"
#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/units.hpp"
#include "sph/simulation/simulate.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

const std::string kPoints = SPH_SOURCE_DIR "/data/example/points.txt";
const std::string kUndeclared = SPH_SOURCE_DIR "/data/example/undeclared/points.txt";

std::string CheckMessage(const CalibrationWorkflowOptions& o) {
  try {
    o.Check();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(CalibrateWorkflow, SevenErrorsAreTheFitsOwnWithTheHeadersSettings) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  std::vector<std::string> stages;
  o.on_stage = [&](const std::string& s) { stages.push_back(s); };
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  CalibrationOptions direct;
  direct.sphere_radius_mm = 20.0;  // the file's header
  direct.probe_offset_mm = 25.0;
  const CalibrationResult expected = Calibrate(ReadPointsFile(kPoints), direct);
  EXPECT_FALSE(run.Extended());
  EXPECT_FALSE(run.trace.has_value());
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_EQ(run.Reported().geometry[static_cast<std::size_t>(p)], expected.geometry[static_cast<std::size_t>(p)]);
  }
  EXPECT_DOUBLE_EQ(run.settings.sphere_radius_mm, 20.0);
  EXPECT_DOUBLE_EQ(run.settings.probe_offset_mm, 25.0);
  EXPECT_TRUE(run.usability.usable);
  ASSERT_TRUE(run.budget.has_value());
  EXPECT_THAT(stages,
              ::testing::ElementsAre("reading " + kPoints, "checking 288 samples", "calibrating the seven errors"));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"program\": \"sph_calibrate "));
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr(kPoints));
  EXPECT_EQ(run.MakeCalibrationFile().probe_offset_mm, 25.0);
}

TEST(CalibrateWorkflow, OptionsWinOverTheHeaderAndNameTheProgram) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  o.sphere_radius_mm = 20.001;
  o.probe_offset_mm = 24.5;
  o.program = "host 2.0";
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  EXPECT_DOUBLE_EQ(run.settings.sphere_radius_mm, 20.001);
  EXPECT_DOUBLE_EQ(run.settings.probe_offset_mm, 24.5);
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"program\": \"host 2.0\""));
}

TEST(CalibrateWorkflow, TracesAndValidatesOnAnotherFile) {
  CalibrationWorkflowOptions o;
  o.validate_path = SPH_SOURCE_DIR "/data/example/undeclared/validate.txt";
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kUndeclared, o);
  ASSERT_TRUE(run.trace.has_value());
  EXPECT_TRUE(run.Extended());  // the example's undeclared effects are found
  ASSERT_TRUE(run.validation.has_value());
  EXPECT_EQ(run.validation->path, o.validate_path);
  EXPECT_EQ(run.validation->n_points, 288);
  EXPECT_THAT(run.validation->note, ::testing::Not(HasSubstr("own points file")));
  bool drift_left_out = false;
  const CalibrationFile file = run.MakeCalibrationFile(&drift_left_out);
  EXPECT_FALSE(file.effects.Empty());
}

// The same readings calibrated again and compared with the first calibration's file: the compare
// file is read before the fit, every parameter is found in both, unchanged, and the reports say so.
TEST(CalibrateWorkflow, ComparesWithAnEarlierCalibrationFile) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  o.conditions.sphere_radius_u_um = 0.1;
  const std::string previous = sph::testing::MakeTempDir("workflow_compare") + "/previous.json";
  WriteCalibrationFile(previous, RunCalibrationWorkflow(kPoints, o).MakeCalibrationFile());
  o.compare_path = previous;
  std::vector<std::string> stages;
  o.on_stage = [&](const std::string& s) { stages.push_back(s); };
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  EXPECT_THAT(stages, ::testing::ElementsAre("reading " + kPoints, "reading " + previous, "checking 288 samples",
                                             "calibrating the seven errors", "comparing with " + previous));
  ASSERT_TRUE(run.comparison.has_value());
  ASSERT_EQ(run.comparison->parameters.size(), 7u);
  for (const ComparedParameter& c : run.comparison->parameters) {
    EXPECT_TRUE(c.Compared()) << c.parameter;
    EXPECT_NEAR(c.difference, 0.0, 1e-9) << c.parameter;
  }
  EXPECT_EQ(run.comparison->correlated_inputs, std::vector<std::string>{"R0 (certificate)"});
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr("comparison with " + previous));
  EXPECT_THAT(text.str(), HasSubstr("verdict: unchanged within uncertainty (7 parameters compared"));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"comparison\": ["));
  EXPECT_THAT(run.HtmlReport(), HasSubstr("Comparison with an earlier calibration"));
}

// A machine with a Theta encoder error (3rd harmonic, 20 arcsec), one placement, noise of `seed`.
PointsData EncoderMachine(std::uint64_t seed) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.effects.model.terms.push_back({Effect::kThetaEncoder, {{3, 0, false}}});
  spec.effects.values.push_back({20.0 * kRadPerArcsec});
  return Simulate(spec);
}

// Two days of one unchanged machine with other models on purpose: the earlier calibration traced
// the residual and added the Theta encoder error, today's fitted the seven errors alone. Today's own seven errors
// hold the encoder's error and differ; refitted with the earlier model they are unchanged within
// uncertainty, and the verdict is taken on that like-for-like comparison.
TEST(CalibrateWorkflow, ComparesLikeWithLikeWhenTheModelsDiffer) {
  CalibrationWorkflowOptions o;
  o.conditions.sphere_radius_u_um = 0.1;
  const std::string previous = sph::testing::MakeTempDir("workflow_like") + "/previous.json";
  WriteCalibrationFile(previous, RunCalibrationWorkflow(EncoderMachine(11), "yesterday.txt", o).MakeCalibrationFile());
  CalibrationWorkflowOptions today;
  today.conditions.sphere_radius_u_um = 0.1;
  today.trace = false;
  today.compare_path = previous;
  std::vector<std::string> warnings;
  today.on_warning = [&](const std::string& w) { warnings.push_back(w); };
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(EncoderMachine(12), "today.txt", today);
  ASSERT_TRUE(run.comparison.has_value());
  const CalibrationComparison& cmp = *run.comparison;
  EXPECT_EQ(cmp.model, kPreviousModel);
  EXPECT_TRUE(cmp.Unchanged()) << cmp.verdict;
  EXPECT_THAT(cmp.verdict, HasSubstr("unchanged within uncertainty"));
  int encoder = 0;
  for (const ComparedParameter& c : cmp.parameters) {
    EXPECT_EQ(c.model, kPreviousModel);
    EXPECT_TRUE(c.Compared()) << c.parameter;
    encoder += c.parameter.rfind("theta_encoder.", 0) == 0;
  }
  EXPECT_GE(encoder, 1);  // the encoder's components compared value for value
  // Today's own model, listed beside: the encoder held by the earlier one only, the seven errors moved.
  ASSERT_FALSE(cmp.todays_model.empty());
  bool own_moved = false;
  for (const ComparedParameter& c : cmp.todays_model) {
    EXPECT_EQ(c.model, kTodaysModel);
    if (c.parameter.rfind("theta_encoder.", 0) == 0) {
      EXPECT_EQ(c.found, ComparedParameter::Found::kPreviousOnly);
    }
    own_moved |= c.Compared() && std::abs(c.En) > 1.0;
  }
  EXPECT_TRUE(own_moved) << "today's own model should differ by the encoder's error";
  EXPECT_THAT(cmp.models, HasSubstr("the earlier model holds theta_encoder."));
  EXPECT_THAT(cmp.models, HasSubstr("today's own model moves "));
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr("today's readings refitted with the earlier calibration's model:\n"));
  EXPECT_THAT(text.str(), HasSubstr("today's own model, for information:\n"));
  EXPECT_THAT(text.str(), HasSubstr("models: the models differ: "));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"model\": \"previous\""));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"model\": \"today\""));
}

// The same readings on both days, the earlier calibration of the seven errors alone, today's traced
// (a drift and encoder terms added): refitted with the earlier model, today's values are the
// earlier ones, drift and all, and today's own model's changes are listed beside.
TEST(CalibrateWorkflow, SameReadingsOfAnotherModelCompareEqualLikeWithLike) {
  CalibrationWorkflowOptions o;
  o.conditions.sphere_radius_u_um = 0.1;
  o.trace = false;
  const std::string previous = sph::testing::MakeTempDir("workflow_same") + "/previous.json";
  WriteCalibrationFile(previous, RunCalibrationWorkflow(kUndeclared, o).MakeCalibrationFile());
  CalibrationWorkflowOptions today;
  today.conditions.sphere_radius_u_um = 0.1;
  today.compare_path = previous;
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kUndeclared, today);
  ASSERT_TRUE(run.Extended());
  ASSERT_GE(run.trace->after.fit.model.Find(Effect::kProbeDrift), 0);
  ASSERT_TRUE(run.comparison.has_value());
  EXPECT_EQ(run.comparison->model, kPreviousModel);
  ASSERT_EQ(run.comparison->parameters.size(), 7u);
  for (const ComparedParameter& c : run.comparison->parameters) {
    EXPECT_TRUE(c.Compared()) << c.parameter;
    EXPECT_NEAR(c.En, 0.0, 1e-6) << c.parameter;
  }
  EXPECT_THAT(run.comparison->verdict, HasSubstr("unchanged within uncertainty (7 parameters compared"));
  EXPECT_THAT(run.comparison->models, HasSubstr("today's own model holds theta_encoder."));
}

// An earlier model that today's readings cannot determine (a reversal error, and no reading says
// from which side its axis came): today's own model compared, the comparison and a warning say why.
TEST(CalibrateWorkflow, ComparesTodaysModelWhenTheEarlierCannotBeFitted) {
  CalibrationWorkflowOptions o;
  o.conditions.sphere_radius_u_um = 0.1;
  o.trace = false;
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(EncoderMachine(12), "today.txt", o);
  CalibrationFile previous = run.MakeCalibrationFile();
  previous.effects.terms.push_back({Effect::kThetaReversal, {{1, 0, false}}});
  previous.effect_values.push_back({0.0});
  const CalibrationComparison cmp = CompareWithEarlier(run, previous, "earlier.json", o);
  EXPECT_EQ(cmp.model, kTodaysModel);
  EXPECT_TRUE(cmp.todays_model.empty());
  EXPECT_THAT(cmp.models, HasSubstr("the earlier model holds theta_reversal.b, today's does not; the earlier "
                                    "calibration's model could not be fitted to today's readings ("));
  EXPECT_THAT(cmp.verdict, HasSubstr("found in one calibration only: theta_reversal.b (previous only)"));
  for (const ComparedParameter& c : cmp.parameters) EXPECT_EQ(c.model, kTodaysModel);
}

// A prior the readings contradict: the example's alpha is 0.0202 deg, stated 0.03 deg with a
// standard uncertainty of 1e-6 deg. Taken on trust it would pull alpha there and the residual with
// it; tested, it is rejected, the calibration is not usable and the reason names both values.
TEST(CalibrateWorkflow, APriorTheReadingsRejectMakesTheCalibrationUnusable) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  o.fit.priors.push_back(ParseParameterPrior("alpha_deg=0.03,1e-6", "--prior alpha_deg=0.03,1e-6"));
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  ASSERT_EQ(run.statements.size(), 1u);
  const StatementCheck& s = run.statements[0];
  EXPECT_EQ(s.kind, StatementKind::kPrior);
  EXPECT_EQ(s.dof, 1);
  EXPECT_TRUE(s.rejected);
  EXPECT_EQ(s.statement, "--prior alpha_deg=0.03,1e-06");
  EXPECT_EQ(s.readings, "alpha_deg=0.02022,0.00019");
  EXPECT_FALSE(run.usability.usable);
  ASSERT_FALSE(run.usability.reasons.empty());
  EXPECT_THAT(run.usability.reasons.back(),
              HasSubstr("the readings reject --prior alpha_deg=0.03,1e-06: stated alpha_deg=0.03,1e-06, the readings "
                        "without it alpha_deg=0.02022,0.00019"));
  EXPECT_THROW(run.MakeCalibrationFile(), Error);
  // Accepted against the readings: usable, and the calibration file says so.
  o.accept_rejected = true;
  const CalibrationWorkflowResult accepted = RunCalibrationWorkflow(kPoints, o);
  EXPECT_TRUE(accepted.usability.usable);
  ASSERT_EQ(accepted.statements.size(), 1u);
  EXPECT_TRUE(accepted.statements[0].rejected);
  EXPECT_TRUE(accepted.statements[0].accepted);
  bool said = false;
  for (const auto& [key, value] : accepted.MakeCalibrationFile().source) {
    said |= key == "accepted_against_the_readings" && value.find("--prior alpha_deg=0.03,1e-06") != std::string::npos;
  }
  EXPECT_TRUE(said);
  // A prior the readings agree with is used, and reported as agreeing.
  o.accept_rejected = false;
  o.fit.priors = {ParseParameterPrior("alpha_deg=0.0202,0.0005", "--prior alpha_deg=0.0202,0.0005")};
  const CalibrationWorkflowResult agreed = RunCalibrationWorkflow(kPoints, o);
  ASSERT_EQ(agreed.statements.size(), 1u);
  EXPECT_FALSE(agreed.statements[0].rejected);
  EXPECT_TRUE(agreed.usability.usable);
}

// A held value of an effect's parameter states that the effect exists: with the trace the effect is
// in the model from the start (a probe gain the example's machine does not have), never removed,
// and the held value is tested like any statement: the readings, the gain free, give -1.9 +- 0.95 um
// against 3 um held.
TEST(CalibrateWorkflow, AFixedEffectParameterPutsItsEffectInTheModelAndIsTested) {
  CalibrationWorkflowOptions o;
  o.fit.fixed.push_back(ParseFixedParameter("probe_gain.u1_um=3", "--fix probe_gain.u1_um=3"));
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  ASSERT_TRUE(run.trace.has_value());
  ASSERT_EQ(run.trace->stated.size(), 1u);
  EXPECT_EQ(run.trace->stated[0], Effect::kProbeGain);
  EXPECT_GE(run.trace->after.fit.model.Find(Effect::kProbeGain), 0);
  ASSERT_FALSE(run.statements.empty());
  EXPECT_EQ(run.statements[0].kind, StatementKind::kFixed);
  EXPECT_EQ(run.statements[0].parameter, "probe_gain.u1");
  EXPECT_EQ(run.statements[0].dof, 1);
  EXPECT_TRUE(run.statements[0].rejected) << run.statements[0].verdict;
  EXPECT_EQ(run.statements[0].readings, "probe_gain.u1_um=-1.91,0.95");
  EXPECT_FALSE(run.usability.usable);
  // Nothing the trace found beside it is applied: the model is the statement's.
  ASSERT_EQ(run.trace->added.size(), 1u);
  EXPECT_EQ(run.trace->added[0], Effect::kProbeGain);
}

// What usable is judged against: 40 readings of the example's machine (8 x 5) determine beta, b,
// epsilon and c far worse than the reference pattern does at their noise; the default says so and
// names itself, a stated requirement is applied instead and named.
TEST(CalibrateWorkflow, UsableAgainstTheDefaultRequirementOrTheStatedOne) {
  SimulationSpec spec;
  spec.pattern = GridPattern(8, 5);
  CalibrationWorkflowOptions o;
  o.trace = false;
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(Simulate(spec), "h40.txt", o);
  EXPECT_FALSE(run.usability.usable);
  EXPECT_THAT(run.usability.requirement, HasSubstr("the default requirement"));
  bool beta = false;
  for (const std::string& why : run.usability.reasons) beta |= why.find("the readings determine beta to ") == 0;
  EXPECT_TRUE(beta);
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"usable_against\": \"the default requirement"));
  o.requirement.max_std_stated = true;  // --max-std-um 10
  const CalibrationWorkflowResult stated = RunCalibrationWorkflow(Simulate(spec), "h40.txt", o);
  EXPECT_TRUE(stated.usability.usable);
  EXPECT_THAT(stated.usability.requirement, HasSubstr("the stated requirement"));
  o.requirement.max_std_stated = false;
  o.requirement.target_u = {{"beta", 100e-6, "beta_urad=100"}};
  const CalibrationWorkflowResult target = RunCalibrationWorkflow(Simulate(spec), "h40.txt", o);
  EXPECT_FALSE(target.usability.usable);
  ASSERT_EQ(target.usability.reasons.size(), 1u);
  EXPECT_THAT(target.usability.reasons[0], HasSubstr("above the stated target --target-u beta_urad=100"));
  // The paper's pattern of the same machine is usable by default.
  SimulationSpec paper;
  o.requirement.target_u.clear();
  EXPECT_TRUE(RunCalibrationWorkflow(Simulate(paper), "paper.txt", o).usability.usable);
}

TEST(CalibrateWorkflow, RefusesPointsWithoutARadius) {
  PointsData points = ReadPointsFile(kPoints);
  points.header.sphere_radius_mm.reset();
  CalibrationWorkflowOptions o;
  try {
    RunCalibrationWorkflow(points, "mine.txt", o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("mine.txt: the reference sphere radius R0 is not given"));
  }
}

TEST(CalibrateWorkflow, StopsWithCancelledWhenItsCancellationIsRequested) {
  Cancellation cancellation;
  const CancellationScope scope(&cancellation);
  CalibrationWorkflowOptions o;
  o.on_stage = [&](const std::string& stage) {
    if (stage == "calibrating the seven errors") cancellation.Request();
  };
  EXPECT_THROW(RunCalibrationWorkflow(kUndeclared, o), Cancelled);
  // Another cancellation, never requested, lets it run.
  Cancellation other;
  const CancellationScope other_scope(&other);
  EXPECT_TRUE(RunCalibrationWorkflow(kPoints, o).usability.usable);
}

// The example with each sample changed by `take`.
PointsData ExampleTaken(void (*take)(Sample&)) {
  PointsData p = ReadPointsFile(kPoints);
  for (Sample& s : p.samples) take(s);
  return p;
}

TEST(CalibrateWorkflow, NamesTheLikelyCauseOfASetUpThatDoesNotFit) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  // A probe that reads the other way: as given, d' and beta far beyond a machine's; taken the other way
  // round, the readings fit to their noise.
  const CalibrationWorkflowResult reversed =
      RunCalibrationWorkflow(ExampleTaken([](Sample& s) { s.r_mm = 10.0 - s.r_mm; }), "reversed.txt", o);
  EXPECT_FALSE(reversed.usability.usable);
  EXPECT_THAT(reversed.likely_cause,
              HasSubstr("likely cause: the probe's reading runs the other way (with r taken as 2 x median(r) - r"));
  EXPECT_EQ(reversed.usability.reasons.back(), reversed.likely_cause);
  EXPECT_THAT(reversed.JsonReport(), HasSubstr("likely cause: the probe's reading runs the other way"));
  const std::optional<Misreading> m = LikelyMisreading(reversed.points, reversed.settings, reversed.seven);
  ASSERT_TRUE(m.has_value());
  EXPECT_LT(m->rms_um, 0.1);  // the example's noise, 0.05 um
  EXPECT_GT(m->given_rms_um, 1.0);
  // Readings in um.
  const CalibrationWorkflowResult in_um =
      RunCalibrationWorkflow(ExampleTaken([](Sample& s) { s.r_mm *= 1000.0; }), "um.txt", o);
  EXPECT_THAT(in_um.likely_cause, HasSubstr("likely cause: the probe's readings are in um, not mm"));
  // Theta in the other sense fits as well as the true one, with alpha and epsilon of the other sign:
  // the readings do not show it, nothing is named.
  const CalibrationWorkflowResult theta =
      RunCalibrationWorkflow(ExampleTaken([](Sample& s) { s.theta_deg = -s.theta_deg; }), "theta.txt", o);
  EXPECT_TRUE(theta.usability.usable);
  EXPECT_EQ(theta.likely_cause, "");
  EXPECT_FALSE(FitsAsAMisreading(theta.points, theta.settings, theta.seven));
}

TEST(CalibrateWorkflow, CheckNamesTheSettingOutOfRange) {
  CalibrationWorkflowOptions o;
  EXPECT_EQ(CheckMessage(o), "");
  o.fit.max_std_um = 0.0;
  EXPECT_THAT(CheckMessage(o), HasSubstr("fit.max_std_um: must be > 0 and <= 1e+06 um, got 0"));
  o = {};
  o.sphere_radius_mm = -1.0;
  EXPECT_THAT(CheckMessage(o), HasSubstr("sphere_radius_mm: must be > 0 and <= 1000 mm, got -1"));
  o = {};
  o.trace_options.drift_order = 4;
  EXPECT_THAT(CheckMessage(o), HasSubstr("trace_options.drift_order: must be >= 1 and <= 3, got 4"));
  o = {};
  o.trace = false;
  o.effects = {Effect::kProbeGain};
  EXPECT_THAT(CheckMessage(o), HasSubstr("effects need trace"));
  o = {};
  o.coverage = 1.0;
  EXPECT_THAT(CheckMessage(o), HasSubstr("coverage: must be >= 0.5 and <= 0.9999, got 1"));
  // The run refuses them as Check() does.
  EXPECT_THROW(RunCalibrationWorkflow(ReadPointsFile(kPoints), kPoints, o), Error);
}

}  // namespace
}  // namespace sph
