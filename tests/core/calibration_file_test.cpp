#include "sph/io/calibration_file.hpp"

#include <cmath>

#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sph/core/error.hpp"
#include "sph/model/units.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

std::string ErrorReading(const std::string& path) {
  try {
    ReadCalibrationFile(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(CalibrationFile, RoundTrips) {
  const std::string dir = sph::testing::MakeTempDir("calfile");
  CalibrationFile cal;
  cal.geometry = {3.5e-4, 0.002, 3.4e-4, 0.0019, 3.6e-4, 0.0021, -0.062};
  cal.probe_offset_mm = 25.0;
  cal.sphere_radius_mm = 20.0;
  Eigen::Matrix<double, 7, 7> cov = Eigen::Matrix<double, 7, 7>::Identity() * 1e-12;
  cov(0, 3) = cov(3, 0) = 2e-13;
  cal.covariance = cov;
  cal.created_by = "test";
  cal.source = {{"points_file", "x.txt"}};
  cal.probe_drift_powers = {1, 2};
  WriteCalibrationFile(dir + "/cal.json", cal);
  const CalibrationFile back = ReadCalibrationFile(dir + "/cal.json");
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_NEAR(back.geometry[static_cast<std::size_t>(p)], cal.geometry[static_cast<std::size_t>(p)], 1e-15);
  }
  EXPECT_DOUBLE_EQ(back.probe_offset_mm, 25.0);
  ASSERT_TRUE(back.covariance.has_value());
  EXPECT_NEAR((*back.covariance)(0, 3), 2e-13, 1e-25);
  EXPECT_EQ(back.source, cal.source);
  EXPECT_EQ(back.probe_drift_powers, cal.probe_drift_powers);
}

TEST(CalibrationFile, RejectsOtherFormatsAndMissingFields) {
  const std::string dir = sph::testing::MakeTempDir("calfile_bad");
  WriteText(dir + "/a.json", "not json");
  EXPECT_THAT(ErrorReading(dir + "/a.json"), HasSubstr("a.json: not valid JSON"));
  WriteText(dir + "/b.json", R"({"format": "other"})");
  EXPECT_THAT(ErrorReading(dir + "/b.json"), HasSubstr("not an sph calibration file"));
  WriteText(dir + "/c.json", R"({"format": "sph-calibration", "format_version": 2})");
  EXPECT_THAT(ErrorReading(dir + "/c.json"), HasSubstr("calibration format version 2 is not supported"));
  WriteText(dir + "/d.json", R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25,
      "geometry": {"alpha": {"value": 0, "unit": "deg"}}, "effects": []})");
  EXPECT_THAT(ErrorReading(dir + "/d.json"), HasSubstr("missing field 'geometry.a'"));
  WriteText(dir + "/e.json", R"({"format": "sph-calibration", "format_version": 1})");
  EXPECT_THAT(ErrorReading(dir + "/e.json"), HasSubstr("missing field 'probe_offset_mm'"));
  EXPECT_THAT(ErrorReading(dir + "/none.json"), HasSubstr("none.json: cannot open"));
}

// A complete, valid file in which one piece of text is replaced.
std::string ValidFile(const std::string& from = "", const std::string& to = "") {
  std::string text = R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25,
    "geometry": {"alpha": {"value": 0.02, "unit": "deg"}, "a": {"value": 0.002, "unit": "mm"},
      "beta": {"value": 0.02, "unit": "deg"}, "b": {"value": 0.002, "unit": "mm"},
      "epsilon": {"value": 0.02, "unit": "deg"}, "c": {"value": 0.002, "unit": "mm"},
      "d_prime": {"value": -0.062, "unit": "mm"}},
    "covariance": {"parameters": ["alpha", "a", "beta", "b", "epsilon", "c", "d_prime"],
      "units": ["deg", "mm", "deg", "mm", "deg", "mm", "mm"],
      "matrix": [[1e-8, 0, 0, 0, 0, 0, 0], [0, 1e-12, 0, 0, 0, 0, 0], [0, 0, 1e-8, 0, 0, 0, 0],
                 [0, 0, 0, 1e-12, 0, 0, 0], [0, 0, 0, 0, 1e-8, 0, 0], [0, 0, 0, 0, 0, 1e-12, 0],
                 [0, 0, 0, 0, 0, 0, 1e-12]]},
    "effects": []})";
  if (!from.empty()) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  return text;
}

TEST(CalibrationFile, LoadsTheCalibrationForCompensation) {
  const std::string dir = sph::testing::MakeTempDir("calfile_load");
  WriteText(dir + "/cal.json", ValidFile());
  const Calibration cal = LoadCalibration(dir + "/cal.json");
  EXPECT_TRUE(cal.IsValid());
  EXPECT_DOUBLE_EQ(cal.probe_offset_mm, 25.0);
  EXPECT_NEAR(cal.geometry[kAlpha], 0.02 * kRadPerDeg, 1e-18);
  EXPECT_DOUBLE_EQ(cal.geometry[kDPrime], -0.062);
  ASSERT_TRUE(cal.covariance.has_value());
  EXPECT_NEAR((*cal.covariance)(kBeta, kBeta), 1e-8 * kRadPerDeg * kRadPerDeg, 1e-24);
  EXPECT_DOUBLE_EQ((*cal.covariance)(kB, kB), 1e-12);
  // Without a covariance the calibration still compensates.
  WriteText(dir + "/nocov.json", ValidFile(R"("covariance")", R"("no_covariance")"));
  EXPECT_FALSE(LoadCalibration(dir + "/nocov.json").covariance.has_value());
}

TEST(CalibrationFile, EffectsGoThroughTheFileAndIntoCompensation) {
  const std::string dir = sph::testing::MakeTempDir("calfile_effects");
  CalibrationFile file;
  file.geometry = {1e-4, 0.002, -2e-4, 0.001, 3e-4, -0.002, -0.06};
  file.probe_offset_mm = 25.0;
  file.effects.terms = {{Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}},
                        {Effect::kThetaRadialMotion, {{3, 1, true}}},
                        {Effect::kProbeGain, {{1, 0, false}}}};
  file.effect_values = {{6 * kRadPerArcsec, -4 * kRadPerArcsec}, {0.1 * kMmPerUm}, {0.4 * kMmPerUm}};
  file.effects.reference = {4.9, 2.1, 0.0, 287.0};
  WriteCalibrationFile(dir + "/cal.json", file);
  const Calibration cal = LoadCalibration(dir + "/cal.json");
  ASSERT_TRUE(cal.IsValid());
  ASSERT_EQ(cal.effects.terms.size(), 3u);
  for (std::size_t t = 0; t < 3; ++t) {
    ASSERT_EQ(cal.effect_values[t].size(), file.effect_values[t].size());
    for (std::size_t i = 0; i < file.effect_values[t].size(); ++i) {
      EXPECT_NEAR(cal.effect_values[t][i], file.effect_values[t][i], 1e-15 * std::abs(file.effect_values[t][i]));
      EXPECT_EQ(cal.effects.terms[t].ParamName(i), file.effects.terms[t].ParamName(i));
    }
  }
  EXPECT_DOUBLE_EQ(cal.effects.reference.r_half_range_mm, 2.1);
  // Compensation applies them: the point is EffectScmsPoint's, and differs from the seven errors' alone.
  const Eigen::Vector3d p = Compensate(cal, 30.0, 60.0, 5.1);
  const Eigen::Vector3d q =
      EffectScmsPoint(cal.geometry, cal.effects, cal.effect_values, EffectReading(30.0, 60.0, 5.1, 0.0), 25.0);
  EXPECT_EQ(p, q);
  EXPECT_GT((p - ScmsPoint(cal.geometry, 30 * kRadPerDeg, 60 * kRadPerDeg, 5.1, 25.0)).norm(), 1e-5);
  // An invalid calibration (a block missing) compensates to NaN rather than reading out of range.
  Calibration broken = cal;
  broken.effect_values.pop_back();
  EXPECT_FALSE(broken.IsValid());
  EXPECT_TRUE(Compensate(broken, 30.0, 60.0, 5.1).array().isNaN().all());
}

// The Phi axis' pivot, the readings the probe terms were fitted over and the ISO 230 names go
// through the file; a pivot beyond the bounds is refused at its field.
TEST(CalibrationFile, PivotFitRangeAndIsoNames) {
  const std::string dir = sph::testing::MakeTempDir("calfile_pivot");
  CalibrationFile file;
  file.probe_offset_mm = 25.0;
  file.effects.terms = {{Effect::kPhiWobble, {{2, 0, false}}},
                        {Effect::kThetaTiltMotion, {{2, 1, true}}},
                        {Effect::kProbeGain, {{1, 0, false}}}};
  file.effect_values = {{3 * kRadPerArcsec}, {-2 * kRadPerArcsec}, {0.4 * kMmPerUm}};
  file.effects.reference = WithProbeRange(EffectReference{4.9, 2.1, 0.0, 287.0, 3.1, 6.8}, 10.0);
  file.effects.phi_wobble_pivot_mm = 82.5;
  WriteCalibrationFile(dir + "/cal.json", file);
  const std::string text = sph::testing::ReadWholeFile(dir + "/cal.json");
  EXPECT_NE(text.find(R"x("iso_name": "EAB, ECB (tilt error motion of B)")x"), std::string::npos) << text;
  EXPECT_NE(text.find(R"x("iso_name": "EAC, EBC (tilt error motion of C)")x"), std::string::npos);
  const Calibration cal = LoadCalibration(dir + "/cal.json");
  ASSERT_TRUE(cal.IsValid());
  EXPECT_EQ(cal.effects.phi_wobble_pivot_mm, 82.5);
  EXPECT_EQ(cal.effects.reference.r_ref_mm, 5.0);
  EXPECT_EQ(cal.effects.reference.r_half_range_mm, 5.0);
  EXPECT_EQ(cal.effects.reference.FitMin(), 3.1);
  EXPECT_EQ(cal.effects.reference.FitMax(), 6.8);
  // Readings outside 3.1 .. 6.8 mm are extrapolated by the gain: two of these four.
  const std::vector<RawReading> readings{{0, 90, 3.0}, {0, 90, 3.1}, {0, 90, 6.8}, {0, 90, 7.2}};
  EXPECT_EQ(ProbeExtrapolations(cal, readings), 2u);
  std::string bad = text;
  bad.replace(bad.find("82.5"), 4, "2e+04");
  WriteText(dir + "/bad.json", bad);
  EXPECT_THAT(ErrorReading(dir + "/bad.json"), HasSubstr("bad.json: field 'effects[0].pivot_mm' is 20000 mm"));
}

TEST(CalibrationFile, NamesEveryMissingOrWrongField) {
  const std::string dir = sph::testing::MakeTempDir("calfile_fields");
  const std::vector<std::pair<std::pair<std::string, std::string>, std::string>> cases{
      {{R"("format_version": 1)", R"("format_version": "1")"}, "calibration format version \"1\" is not supported"},
      {{R"("format_version": 1)", R"("format_version": 1.5)"}, "calibration format version 1.5 is not supported"},
      {{R"("format_version": 1,)", ""}, "missing field 'format_version'"},
      {{R"("probe_offset_mm": 25)", R"("probe_offset_mm": -25)"}, "probe_offset_mm must be positive"},
      {{R"("probe_offset_mm": 25)", R"("probe_offset_mm": "25")"}, "field 'probe_offset_mm' must be a number"},
      {{R"("geometry")", R"("geometrie")"}, "missing field 'geometry'"},
      {{R"("d_prime": {"value": -0.062, "unit": "mm"})", R"("d_prime": {"unit": "mm"})"},
       "missing field 'geometry.d_prime.value'"},
      {{R"("beta": {"value": 0.02, "unit": "deg"})", R"("beta": {"value": 0.02, "unit": "rad"})"},
       "field 'geometry.beta.unit' must be \"deg\""},
      {{R"("beta": {"value": 0.02, "unit": "deg"})", R"("beta": {"value": 0.02})"},
       "missing field 'geometry.beta.unit'"},
      {{R"("parameters": ["alpha", "a", "beta", "b")", R"("parameters": ["a", "alpha", "beta", "b")"},
       "field 'covariance.parameters' must be [\"alpha\",\"a\",\"beta\",\"b\",\"epsilon\",\"c\",\"d_prime\"]"},
      {{R"("units": ["deg", "mm")", R"("units": ["rad", "mm")"}, "field 'covariance.units' must be"},
      {{R"("units": [)", R"("unit": [)"}, "missing field 'covariance.units'"},
      {{R"([0, 0, 0, 0, 0, 0, 1e-12]]})", R"([0, 0, 0, 0, 0, 0]]})"}, "covariance.matrix must be 7 x 7"},
      {{R"(,
    "effects": [])",
        ""},
       "missing field 'effects'"},
      {{R"("effects": [])", R"("effects": [{"name": "encoder"}])"}, "missing field 'effects[0].id'"},
      {{R"("effects": [])", R"("effects": [{"id": "encoder"}])"}, "field 'effects[0].id': unknown effect \"encoder\""},
      {{R"("effects": [])", R"("effects": [{"id": "probe_drift", "parameters": []}])"},
       "field 'effects[0].id': probe_drift belongs to the run it was measured in"},
      {{R"("effects": [])", R"("effects": [{"id": "probe_gain", "parameters": []}])"},
       "field 'effects[0].parameters' must be a non-empty array"},
      {{R"("effects": [])",
        R"("effects": [{"id": "probe_gain", "parameters": [{"name": "probe_gain.c2", "value": 1, "unit": "um"}]}])"},
       "field 'effects[0].parameters[0].name': \"probe_gain.c2\" is no parameter of probe_gain"},
      {{R"("effects": [])",
        R"("effects": [{"id": "theta_encoder", "parameters": [{"name": "theta_encoder.c2", "value": 1, "unit": "um"}]}])"},
       "field 'effects[0].parameters[0].unit' must be \"arcsec\""},
      {{R"("effects": [])",
        R"("effects": [{"id": "probe_gain", "parameters": [{"name": "probe_gain.u1", "value": 1, "unit": "um"}]}])"},
       "missing field 'effect_reference'"},
      {{R"("effects": [])",
        R"("effects": [{"id": "probe_gain", "parameters": [{"name": "probe_gain.u1", "value": 1, "unit": "um"}]}],
        "effect_reference": {"r_ref_mm": 5, "r_half_range_mm": 1e-300, "t_start_s": 0, "t_span_s": 1})"},
       "field 'effect_reference': r_half_range_mm must be at least"},
      {{R"("effects": [])", R"("effects": [], "probe_drift_powers": [2, 1])"},
       "field 'probe_drift_powers' must list ascending powers of tau from 1 to 3, got [2,1]"},
      {{R"("effects": [])", R"("effects": [], "probe_drift_powers": [4])"},
       "field 'probe_drift_powers' must list ascending powers of tau from 1 to 3, got [4]"},
  };
  int i = 0;
  for (const auto& [edit, message] : cases) {
    const std::string path = dir + "/f" + std::to_string(i++) + ".json";
    WriteText(path, ValidFile(edit.first, edit.second));
    EXPECT_THAT(ErrorReading(path), HasSubstr(path + ": " + message)) << edit.second;
  }
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

// The calibration sphere's form goes through the file; the reader names what is wrong with it.
TEST(CalibrationFile, SphereFormRoundTripsAndIsValidated) {
  const std::string dir = sph::testing::MakeTempDir("calfile_form");
  CalibrationFile cal;
  cal.probe_offset_mm = 25.0;
  cal.form_terms = {{2, 0}, {3, -2}, {8, 8}};
  cal.form_values_mm = {6e-5, -2.5e-5, 1e-6};
  cal.form_std_mm = {4e-6, 5e-6, 6e-6};
  WriteCalibrationFile(dir + "/cal.json", cal);
  const CalibrationFile back = ReadCalibrationFile(dir + "/cal.json");
  ASSERT_EQ(back.form_terms, cal.form_terms);
  ASSERT_EQ(back.form_std_mm.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(back.form_values_mm[k], cal.form_values_mm[k], 1e-18);
    EXPECT_NEAR(back.form_std_mm[k], cal.form_std_mm[k], 1e-18);
  }
  std::ifstream in(dir + "/cal.json");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string head = R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25,
    "geometry": {"alpha": {"value": 0, "unit": "deg"}, "a": {"value": 0, "unit": "mm"},
    "beta": {"value": 0, "unit": "deg"}, "b": {"value": 0, "unit": "mm"}, "epsilon": {"value": 0, "unit": "deg"},
    "c": {"value": 0, "unit": "mm"}, "d_prime": {"value": 0, "unit": "mm"}}, "effects": [], "sphere_form": )";
  const std::string ok = R"("normalisation": "schmidt_semi_normalised", "frame": "body", "unit": "um", )";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"normalisation": "orthonormal", "frame": "body", "unit": "um", "terms": []})",
       "sphere_form.normalisation' must be \"schmidt_semi_normalised\""},
      {R"({"normalisation": "schmidt_semi_normalised", "frame": "body", "unit": "mm", "terms": []})",
       "sphere_form.unit' must be \"um\""},
      {"{" + ok + R"("terms": [{"l": 1, "m": 0, "value_um": 0.1}]})", "a form term has 2 <= l <= 40 and |m| <= l"},
      {"{" + ok + R"("terms": [{"l": 3, "m": 4, "value_um": 0.1}]})", "a form term has 2 <= l <= 40 and |m| <= l"},
      {"{" + ok + R"("terms": [{"l": 3, "m": 1, "value_um": 0.1}, {"l": 3, "m": 1, "value_um": 0.2}]})",
       "the term l = 3, m = 1 is listed twice"},
      {"{" + ok + R"("terms": [{"l": 3, "m": 1, "value_um": 1e6}]})", "a form term lies within 1000 um"},
      {"{" + ok + R"("terms": [{"l": 3, "m": 1}]})", "sphere_form.terms[0].value_um"},
  };
  for (std::size_t k = 0; k < bad.size(); ++k) {
    const std::string path = dir + "/bad" + std::to_string(k) + ".json";
    WriteText(path, head + bad[k].first + "}");
    EXPECT_THAT(ErrorReading(path), HasSubstr(bad[k].second)) << bad[k].first;
  }
  EXPECT_THAT(text, HasSubstr("\"normalisation\": \"schmidt_semi_normalised\""));
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

// The covariance of every parameter applied goes through the file in the units it is stored in,
// with the Type B inputs it holds; a file of the seven errors' block alone is read as before.
TEST(CalibrationFile, FullCovarianceOfErrorsEffectsAndFormRoundTrips) {
  const std::string dir = sph::testing::MakeTempDir("calfile_fullcov");
  CalibrationFile cal;
  cal.geometry = {1e-4, 0.002, -2e-4, 0.001, 3e-4, -0.002, -0.06};
  cal.probe_offset_mm = 25.0;
  cal.effects.terms = {{Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}}, {Effect::kProbeGain, {{1, 0, false}}}};
  cal.effect_values = {{6 * kRadPerArcsec, -4 * kRadPerArcsec}, {0.4 * kMmPerUm}};
  cal.effects.reference = {4.9, 2.1, 0.0, 287.0};
  cal.form_terms = {{2, 0}, {3, -2}};
  cal.form_values_mm = {6e-5, -2.5e-5};
  // A covariance of 7 + 3 + 2 parameters with correlations across the blocks (internal units).
  Eigen::VectorXd sd(12);
  sd << 2e-6, 2e-4, 2e-5, 5e-4, 2e-5, 5e-4, 1e-4, 0.7 * kRadPerArcsec, 0.6 * kRadPerArcsec, 8e-6, 2e-6, 3e-6;
  Eigen::MatrixXd corr = Eigen::MatrixXd::Identity(12, 12);
  corr(0, 7) = corr(7, 0) = 0.5;    // alpha with theta_encoder.c2
  corr(6, 9) = corr(9, 6) = -0.9;   // d' with probe_gain.u1
  corr(8, 11) = corr(11, 8) = 0.3;  // theta_encoder.s3 with S(3,-2)
  cal.parameter_covariance = sd.asDiagonal() * corr * sd.asDiagonal();
  cal.covariance = cal.parameter_covariance.topLeftCorner<7, 7>();
  Eigen::VectorXd s_r0 = Eigen::VectorXd::Zero(12);
  s_r0(6) = 1.0056e-3;  // d' per um of R0 [mm/um]
  s_r0(9) = 2e-5;
  cal.covariance_inputs = {{"R0 (certificate)", "um", 0.02, s_r0}};  // within what the matrix holds
  cal.covariance_type_a_dof = 571;
  WriteCalibrationFile(dir + "/cal.json", cal);

  const CalibrationFile back = ReadCalibrationFile(dir + "/cal.json");
  EXPECT_EQ(
      CalibrationParameterNames(back),
      (std::vector<std::string>{"alpha", "a", "beta", "b", "epsilon", "c", "d_prime", "theta_encoder.c2",
                                "theta_encoder.s3", "probe_gain.u1", "sphere_form.S(2,0)", "sphere_form.S(3,-2)"}));
  ASSERT_EQ(back.parameter_covariance.rows(), 12);
  EXPECT_TRUE(back.parameter_covariance.isApprox(cal.parameter_covariance, 1e-14));
  ASSERT_TRUE(back.covariance.has_value());
  EXPECT_TRUE(back.covariance->isApprox(cal.parameter_covariance.topLeftCorner<7, 7>(), 1e-14));
  EXPECT_TRUE(AppliedCovariance(back).isApprox(cal.parameter_covariance, 1e-14));
  ASSERT_EQ(back.covariance_inputs.size(), 1u);
  EXPECT_EQ(back.covariance_inputs[0].input, "R0 (certificate)");
  EXPECT_EQ(back.covariance_inputs[0].unit, "um");
  EXPECT_DOUBLE_EQ(back.covariance_inputs[0].u, 0.02);
  EXPECT_TRUE(back.covariance_inputs[0].per_unit.isApprox(s_r0, 1e-14));
  EXPECT_DOUBLE_EQ(back.covariance_type_a_dof, 571.0);

  // Stored in the units the parameters are stored in: the encoder's variance in arcsec^2, the
  // gain's and the form's in um^2, the cross term of d' and the gain in mm um.
  std::ifstream in(dir + "/cal.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& m = j["covariance"]["matrix"];
  EXPECT_NEAR(m[7][7].get<double>(), 0.49, 1e-12);
  EXPECT_NEAR(m[9][9].get<double>(), 64.0 * 1e-6, 1e-15);
  EXPECT_NEAR(m[6][9].get<double>(), -0.9 * 1e-4 * 8e-3, 1e-15);
  EXPECT_NEAR(m[10][10].get<double>(), 4e-6, 1e-15);
  EXPECT_EQ(j["covariance"]["units"][7], "arcsec");
  EXPECT_EQ(j["covariance"]["units"][11], "um");
  EXPECT_NEAR(j["covariance"]["inputs"][0]["sensitivity"][6].get<double>(), 1.0056e-3, 1e-15);

  // The same file with the seven errors' block alone: read as before, the effects without covariance.
  CalibrationFile seven = cal;
  seven.parameter_covariance.resize(0, 0);
  seven.covariance_inputs.clear();
  WriteCalibrationFile(dir + "/seven.json", seven);
  const CalibrationFile old = ReadCalibrationFile(dir + "/seven.json");
  EXPECT_EQ(old.parameter_covariance.size(), 0);
  ASSERT_TRUE(old.covariance.has_value());
  EXPECT_EQ(AppliedCovariance(old).rows(), 7);

  // Another list of parameters is refused, naming both it accepts.
  std::string text = nlohmann::json(j).dump();
  const std::string from = "\"theta_encoder.s3\",\"probe_gain.u1\"";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "\"probe_gain.u1\",\"theta_encoder.s3\"");
  WriteText(dir + "/swapped.json", text);
  EXPECT_THAT(
      ErrorReading(dir + "/swapped.json"),
      HasSubstr("swapped.json: field 'covariance.parameters' must be [\"alpha\",\"a\",\"beta\",\"b\",\"epsilon\","
                "\"c\",\"d_prime\"] (the seven errors') or [\"alpha\""));
  // An input's sensitivity of the wrong length.
  nlohmann::json short_input = j;
  short_input["covariance"]["inputs"][0]["sensitivity"].erase(0);
  WriteText(dir + "/short.json", short_input.dump());
  EXPECT_THAT(ErrorReading(dir + "/short.json"),
              HasSubstr("field 'covariance.inputs[0].sensitivity' must hold 12 numbers, one per covariance parameter"));
}

// The form's covariance (FormCovariance()) is its block of the full covariance, read back as
// written, correlations and all; a file with the form's standard uncertainties alone (older files,
// or a covariance left out) gives their squares, uncorrelated, and says so.
TEST(CalibrationFile, TheFormsCovarianceRoundTrips) {
  const std::string dir = sph::testing::MakeTempDir("calfile_formcov");
  CalibrationFile cal;
  cal.probe_offset_mm = 25.0;
  cal.sphere_radius_mm = 20.0;
  cal.form_terms = {{2, 0}, {2, 1}, {3, -2}};
  cal.form_values_mm = {6e-5, 1e-5, -2.5e-5};
  cal.form_std_mm = {2e-6, 3e-6, 4e-6};
  Eigen::VectorXd sd(10);
  sd << 2e-6, 2e-4, 2e-5, 5e-4, 2e-5, 5e-4, 1e-4, 2e-6, 3e-6, 4e-6;
  Eigen::MatrixXd corr = Eigen::MatrixXd::Identity(10, 10);
  corr(7, 8) = corr(8, 7) = -0.6;  // S(2,0) with S(2,1)
  corr(8, 9) = corr(9, 8) = 0.4;   // S(2,1) with S(3,-2)
  corr(0, 9) = corr(9, 0) = 0.2;   // alpha with S(3,-2): not part of the form's block
  cal.parameter_covariance = sd.asDiagonal() * corr * sd.asDiagonal();
  cal.covariance = cal.parameter_covariance.topLeftCorner<7, 7>();
  WriteCalibrationFile(dir + "/form.json", cal);
  const CalibrationFile back = ReadCalibrationFile(dir + "/form.json");
  bool correlated = false;
  const Eigen::MatrixXd c = FormCovariance(back, &correlated);
  EXPECT_TRUE(correlated);
  ASSERT_EQ(c.rows(), 3);
  EXPECT_TRUE(c.isApprox(cal.parameter_covariance.bottomRightCorner(3, 3), 1e-14));
  EXPECT_NEAR(c(0, 1), -0.6 * 2e-6 * 3e-6, 1e-24);

  CalibrationFile stds = cal;
  stds.parameter_covariance.resize(0, 0);
  WriteCalibrationFile(dir + "/stds.json", stds);
  const Eigen::MatrixXd d = FormCovariance(ReadCalibrationFile(dir + "/stds.json"), &correlated);
  EXPECT_FALSE(correlated);
  ASSERT_EQ(d.rows(), 3);
  EXPECT_NEAR(d(1, 1), 9e-12, 1e-26);
  EXPECT_EQ(d(0, 1), 0.0);

  CalibrationFile bare = stds;
  bare.form_std_mm.clear();
  EXPECT_EQ(FormCovariance(bare).rows(), 0);
}

// ---- input a calibration file must not get through ---------------------------------------------------

// `depth` arrays around `inner`.
std::string Nested(int depth, const std::string& inner) {
  return std::string(static_cast<std::size_t>(depth), '[') + inner + std::string(static_cast<std::size_t>(depth), ']');
}

// A field nested 70 000 deep (a 140 KB file) is refused before anything recurses over it: the
// reader's message, the copy of "source".
TEST(CalibrationFile, DeepNestingIsRefusedBeforeAnythingRecursesOverIt) {
  const std::string dir = sph::testing::MakeTempDir("calfile_deep");
  const std::vector<std::pair<std::string, std::string>> cases{
      {R"("format_version": 1)", R"("format_version": )" + Nested(70000, "1")},
      {R"("effects": [])", R"("effects": [{"id": )" + Nested(70000, "\"x\"") + "}]"},
      {R"("effects": [])", R"("effects": [], "source": {"points_file": )" + Nested(70000, "") + "}"},
  };
  int i = 0;
  for (const auto& [from, to] : cases) {
    const std::string path = dir + "/d" + std::to_string(i++) + ".json";
    WriteText(path, ValidFile(from, to));
    EXPECT_THAT(ErrorReading(path), HasSubstr(path + ": arrays and objects nested deeper than 64 levels (at '"));
  }
  EXPECT_THAT(ErrorReading(dir + "/d0.json"), HasSubstr("(at 'format_version[0][0][0][0][0][0][0][0][0...' ("));
  // Within the bound a value of "source" is copied as JSON.
  WriteText(dir + "/ok.json",
            ValidFile(R"("effects": [])", R"("effects": [], "source": {"x": )" + Nested(62, "1") + ", \"y\": \"s\"}"));
  const CalibrationFile ok = ReadCalibrationFile(dir + "/ok.json");
  EXPECT_EQ(ok.source, (std::vector<std::pair<std::string, std::string>>{{"x", Nested(62, "1")}, {"y", "s"}}));
  // A message quotes an excerpt of a value, never the whole of it.
  WriteText(dir + "/long.json",
            ValidFile(R"("effects": [])", R"("effects": [{"id": ")" + std::string(100000, 'x') + "\"}]"));
  EXPECT_THAT(ErrorReading(dir + "/long.json"), HasSubstr("field 'effects[0].id': unknown effect \"" +
                                                          std::string(40, 'x') + "\"... (100000 characters)"));
  WriteText(dir + "/array.json", ValidFile(R"("format_version": 1)", R"("format_version": [1, 2, 3])"));
  EXPECT_THAT(ErrorReading(dir + "/array.json"),
              HasSubstr("calibration format version an array of 3 values is not supported"));
}

// JSON keeps one of two values of a key silently: the reader refuses the file, naming the key.
TEST(CalibrationFile, AKeyGivenTwiceIsRefusedNamingIt) {
  const std::string dir = sph::testing::MakeTempDir("calfile_twice");
  const std::vector<std::pair<std::pair<std::string, std::string>, std::string>> cases{
      {{R"("a": {"value": 0.002, "unit": "mm"},)",
        R"("a": {"value": 0.002, "unit": "mm"}, "alpha": {"value": 5, "unit": "deg"},)"},
       "key 'geometry.alpha' is given twice (JSON would keep one of them silently): give each key once"},
      {{R"("probe_offset_mm": 25,)", R"("probe_offset_mm": 25, "probe_offset_mm": 30,)"},
       "key 'probe_offset_mm' is given twice"},
      {{R"("effects": [])",
        R"("effects": [{"id": "probe_gain", "parameters": [{"name": "probe_gain.u1", "value": 1, "unit": "um",
           "value": 900}]}])"},
       "key 'effects[0].parameters[0].value' is given twice"},
  };
  int i = 0;
  for (const auto& [edit, message] : cases) {
    const std::string path = dir + "/t" + std::to_string(i++) + ".json";
    WriteText(path, ValidFile(edit.first, edit.second));
    EXPECT_THAT(ErrorReading(path), HasSubstr(path + ": " + message)) << edit.second;
  }
}

TEST(CalibrationFile, AFieldOfGeometryTheFormatDoesNotKnowIsRefused) {
  const std::string dir = sph::testing::MakeTempDir("calfile_geometry");
  WriteText(dir + "/g.json", ValidFile(R"("d_prime": {"value": -0.062, "unit": "mm"})",
                                       R"("d_prime": {"value": -0.062, "unit": "mm"}, "gamma": {"value": 1})"));
  EXPECT_THAT(
      ErrorReading(dir + "/g.json"),
      HasSubstr("g.json: field 'geometry.gamma' is unknown (the seven errors: alpha a beta b epsilon c d_prime)"));
  WriteText(dir + "/h.json", ValidFile(R"("geometry": {)", R"("geometry": [{)"));
  EXPECT_THAT(ErrorReading(dir + "/h.json"), HasSubstr("not valid JSON"));
}

TEST(CalibrationFile, AFormTermsStandardUncertaintyIsChecked) {
  const std::string dir = sph::testing::MakeTempDir("calfile_std");
  const std::string form = R"("effects": [], "sphere_form": {"normalisation": "schmidt_semi_normalised",
      "frame": "body", "unit": "um", "terms": [{"l": 2, "m": 0, "value_um": 0.06, "std_um": STD}]})";
  const auto with = [&](const std::string& std_um) {
    std::string f = form;
    f.replace(f.find("STD"), 3, std_um);
    return ValidFile(R"("effects": [])", f);
  };
  WriteText(dir + "/neg.json", with("-1"));
  EXPECT_THAT(ErrorReading(dir + "/neg.json"),
              HasSubstr("neg.json: field 'sphere_form.terms[0].std_um' is -1 um: a standard uncertainty is >= 0, and "
                        "one of a form term within 1000 um"));
  WriteText(dir + "/huge.json", with("1e308"));
  EXPECT_THAT(ErrorReading(dir + "/huge.json"), HasSubstr("field 'sphere_form.terms[0].std_um' is 1e+308 um"));
  WriteText(dir + "/text.json", with("\"small\""));
  EXPECT_THAT(ErrorReading(dir + "/text.json"), HasSubstr("field 'sphere_form.terms[0].std_um' must be a number"));
  WriteText(dir + "/ok.json", with("0.004"));
  EXPECT_NEAR(ReadCalibrationFile(dir + "/ok.json").form_std_mm.at(0), 4e-6, 1e-18);
}

// A covariance is a calibration's: no standard uncertainty larger than any value of its
// parameter, and the Type B inputs it says it holds within it.
TEST(CalibrationFile, ACovarianceThatIsNoCalibrationsIsRefused) {
  const std::string dir = sph::testing::MakeTempDir("calfile_cov");
  const std::vector<std::pair<std::pair<std::string, std::string>, std::string>> cases{
      {{"[0, 0, 0, 0, 0, 0, 1e-12]]", "[0, 0, 0, 0, 0, 0, 1e300]]"},
       "covariance.matrix: the standard uncertainty of d_prime is 1e+150 mm, more than any value of it (within 25 "
       "mm): not the covariance of a calibration"},
      {{"[[1e-8, 0,", "[[200, 0,"},
       "covariance.matrix: the standard uncertainty of alpha is 14.1421 deg, more than any value of it (within 10 "
       "deg)"},
      // An input larger than the matrix holds: the Type A part would be negative.
      {{"1e-12]]}", R"x(1e-12]], "inputs": [{"input": "R0 (certificate)", "unit": "um", "u": 10,
          "sensitivity": [0, 0, 0, 0, 0, 0, 1e-3]}]})x"},
       "covariance.inputs: the inputs give d_prime a variance of 0.0001 mm^2, more than covariance.matrix holds "
       "(1e-12 mm^2; the largest part from covariance.inputs[0], 'R0 (certificate)'): the matrix is not the sum of a "
       "Type A part and these inputs"},
      // Within every variance, but not in the correlation of c and d': the Type A part is indefinite.
      {{"1e-12]]}", R"x(1e-12]], "inputs": [{"input": "R0 (certificate)", "unit": "um", "u": 1,
          "sensitivity": [0, 0, 0, 0, 0, 0.8e-6, 0.8e-6]}]})x"},
       "covariance.inputs: the matrix less its inputs (covariance.inputs[0], 'R0 (certificate)', alone) is not "
       "positive semi-definite (eigenvalue -0.28 of the correlation)"},
      {{"1e-12]]}", R"x(1e-12]], "inputs": [{"input": "R0 (certificate)", "unit": "um", "u": 1e308,
          "sensitivity": [0, 0, 0, 0, 0, 0, 0]}]})x"},
       "field 'covariance.inputs[0].u' is 1e+308 um: the standard uncertainty of an input in um lies within [0, "
       "1000]"},
      {{"1e-12]]}", R"x(1e-12]], "inputs": [{"input": "sphere temperature", "unit": "K", "u": 51,
          "sensitivity": [0, 0, 0, 0, 0, 0, 0]}]})x"},
       "field 'covariance.inputs[0].u' is 51 K: the standard uncertainty of an input in K lies within [0, 50]"},
      {{"1e-12]]}", R"x(1e-12]], "inputs": [{"input": "R0", "unit": "furlong", "u": 1,
          "sensitivity": [0, 0, 0, 0, 0, 0, 0]}]})x"},
       "field 'covariance.inputs[0].unit' is 'furlong': an input of the budget is in um, K or relative"},
  };
  int i = 0;
  for (const auto& [edit, message] : cases) {
    const std::string path = dir + "/c" + std::to_string(i++) + ".json";
    WriteText(path, ValidFile(edit.first, edit.second));
    EXPECT_THAT(ErrorReading(path), HasSubstr(path + ": " + message)) << edit.second;
  }
  // Inputs the matrix holds, to its last digit: read.
  WriteText(dir + "/held.json",
            ValidFile("1e-12]]}", R"x(1e-12]], "inputs": [{"input": "probe scale", "unit": "relative", "u": 0.5,
                "sensitivity": [0, 0, 0, 0, 0, 0, 2e-6]}]})x"));
  EXPECT_EQ(ReadCalibrationFile(dir + "/held.json").covariance_inputs.size(), 1u);
}

// /dev/zero as a calibration file is refused at its first NUL byte, after a bounded read.
TEST(CalibrationFile, ANulIsRefusedAfterABoundedRead) {
  sph::testing::RepeatedBytes zeros('\0', std::size_t{64} << 20);
  std::istream z(&zeros);
  try {
    ParseCalibration(z, "zero");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "zero:1: binary data (NUL byte): this is not a calibration file");
  }
  EXPECT_LE(zeros.consumed(), std::size_t{1} << 17);
  std::istringstream text(ValidFile() + "\n\n" + std::string(1, '\0'));  // the NUL at line 13
  try {
    ParseCalibration(text, "t.json");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "t.json:13: binary data (NUL byte): this is not a calibration file");
  }
}

}  // namespace
}  // namespace sph
