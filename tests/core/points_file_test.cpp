#include "sph/io/points_file.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/model/units.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

PointsData Parse(const std::string& text) {
  std::istringstream in(text);
  return ParsePoints(in, "pts.txt");
}

// The error message of parsing `text`, or "" if it parsed.
std::string ErrorOf(const std::string& text) {
  try {
    Parse(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

constexpr const char* kHeader = "# sph-points 1\n# sphere_radius_mm: 20\n# probe_offset_mm: 25\n";

// The direction of approach of each axis, from the rows' order within each setup.
TEST(MotionDirections, FollowTheReadingOrderWithinEachSetup) {
  auto sample = [](double theta, double phi, int setup) {
    Sample s;
    s.theta_deg = theta;
    s.phi_deg = phi;
    s.setup = setup;
    return s;
  };
  const std::vector<Sample> samples{
      sample(0.0, 30.0, 0),       // theta: before its first move, the direction of that move (+)
      sample(90.0, 30.0, 0),      // + ; phi has not moved yet: its first move's direction (-)
      sample(90.0, 30.0, 1),      // another setup: its own first row (theta never moves there: +)
      sample(90.00005, 20.0, 0),  // theta within kStandstillDeg: keeps +; phi -
      sample(45.0, 20.0, 0),      // theta -; phi stands: keeps -
      sample(90.0, 60.0, 1),      // setup 1: phi + (from 30 in that setup, not from 20 in setup 0)
      sample(350.0, 20.0, 0),     // 45 -> 350: the shorter way round is -55 deg: -
      sample(10.0, 20.0, 0),      // 350 -> 10: +20 deg through 360: +
  };
  const std::vector<MotionDirection> d = MotionDirections(samples);
  ASSERT_EQ(d.size(), samples.size());
  const std::vector<int> theta{1, 1, 1, 1, -1, 1, -1, 1}, phi{-1, -1, 1, -1, -1, 1, -1, -1};
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_EQ(d[i].theta, theta[i]) << "row " << i;
    EXPECT_EQ(d[i].phi, phi[i]) << "row " << i;
  }
}

TEST(PointsFile, ReadsHeaderColumnsAndSamples) {
  const PointsData d = Parse(std::string(kHeader) +
                             "# operator: A. Smith\n# columns: theta_deg phi_deg r_mm t_s setup\n"
                             "0.000000 7.500000 5.0912345 0.00 0\n"
                             "# a comment between samples: value\n"
                             "15 7.5 5.1 1.5 3\r\n");
  EXPECT_EQ(d.source, "pts.txt");
  EXPECT_DOUBLE_EQ(*d.header.sphere_radius_mm, 20.0);
  EXPECT_DOUBLE_EQ(*d.header.probe_offset_mm, 25.0);
  ASSERT_EQ(d.header.metadata.size(), 1u);
  EXPECT_EQ(d.header.metadata[0].first, "operator");
  EXPECT_EQ(d.header.metadata[0].second, "A. Smith");
  ASSERT_EQ(d.samples.size(), 2u);
  EXPECT_TRUE(d.has_time);
  EXPECT_TRUE(d.has_setup);
  EXPECT_DOUBLE_EQ(d.samples[0].r_mm, 5.0912345);
  EXPECT_DOUBLE_EQ(d.samples[1].theta_deg, 15.0);
  EXPECT_DOUBLE_EQ(d.samples[1].t_s, 1.5);
  EXPECT_EQ(d.samples[1].setup, 3);
  EXPECT_EQ(d.SetupIds(), (std::vector<int>{0, 3}));
}

// "fix" and "prior": what the run states about the calibration's parameters, units in the names,
// checked at their line and kept (as metadata, written back as they were).
TEST(PointsFile, FixAndPriorHeaderFields) {
  const PointsData d = Parse(std::string(kHeader) +
                             "# fix: d_prime_mm=-0.062 beta\n"
                             "# prior: alpha_deg=0.02,0.0005 theta_encoder.c2_arcsec=6,1.5\n1 2 3\n");
  const std::vector<FixedParameter> fixed = FixedParametersOf(d.header);
  ASSERT_EQ(fixed.size(), 2u);
  EXPECT_EQ(fixed[0].name, "d_prime");
  EXPECT_DOUBLE_EQ(*fixed[0].value, -0.062);
  EXPECT_EQ(fixed[1].name, "beta");
  EXPECT_FALSE(fixed[1].value.has_value());
  const std::vector<ParameterPrior> priors = ParameterPriorsOf(d.header);
  ASSERT_EQ(priors.size(), 2u);
  EXPECT_EQ(priors[0].name, "alpha");
  EXPECT_DOUBLE_EQ(priors[0].value, 0.02 * kRadPerDeg);
  EXPECT_DOUBLE_EQ(priors[0].u, 0.0005 * kRadPerDeg);
  EXPECT_EQ(priors[1].name, "theta_encoder.c2");
  EXPECT_DOUBLE_EQ(priors[1].u, 1.5 * kRadPerArcsec);
  std::ostringstream out;
  WritePoints(out, d);
  EXPECT_THAT(out.str(), HasSubstr("# fix: d_prime_mm=-0.062 beta\n"));
  EXPECT_THAT(out.str(), HasSubstr("# prior: alpha_deg=0.02,0.0005 theta_encoder.c2_arcsec=6,1.5\n"));
  EXPECT_EQ(ParameterPriorText(priors[0]), "alpha_deg=0.02,0.0005");
  EXPECT_EQ(FixedParameterText(fixed[0]), "d_prime_mm=-0.062");
  EXPECT_EQ(ParameterPriorText(priors[1]), "theta_encoder.c2_arcsec=6,1.5");
}

TEST(PointsFile, BadFixAndPriorNamedAtTheirLine) {
  const std::string h = kHeader;
  EXPECT_THAT(ErrorOf(h + "# fix: d_primo\n1 2 3\n"), HasSubstr("pts.txt:4: fix: unknown parameter 'd_primo'"));
  EXPECT_THAT(ErrorOf(h + "# fix: d_prime=-0.06\n1 2 3\n"),
              HasSubstr("pts.txt:4: fix: the value of d_prime needs its unit in the name: d_prime_mm or _um"));
  EXPECT_THAT(ErrorOf(h + "# fix: alpha_mm=0.1\n1 2 3\n"),
              HasSubstr("pts.txt:4: fix: alpha is an angle: give it in deg, arcsec or urad"));
  EXPECT_THAT(ErrorOf(h + "# prior: alpha_deg=0.02\n1 2 3\n"),
              HasSubstr("pts.txt:4: prior: expected NAME_UNIT=VALUE,U"));
  EXPECT_THAT(ErrorOf(h + "# prior: alpha_deg=0.02,0\n1 2 3\n"),
              HasSubstr("pts.txt:4: prior: the standard uncertainty of alpha: must be >= 5.72958e-11 and <= 10 deg, "
                        "got 0"));
  EXPECT_THAT(ErrorOf(h + "# prior: theta_encoder.q2_arcsec=1,1\n1 2 3\n"),
              HasSubstr("pts.txt:4: prior: unknown parameter 'theta_encoder.q2'"));
  EXPECT_THAT(ErrorOf(h + "# prior: alpha_deg=x,1\n1 2 3\n"),
              HasSubstr("pts.txt:4: prior: alpha: 'x' is not a number"));
  EXPECT_THAT(ErrorOf(h + "# fix:\n1 2 3\n"), HasSubstr("pts.txt:4: fix: names no parameter"));
}

// A prior's value and standard uncertainty, and a held value, lie in the range the parameter's
// values have (kScmsParamInfo's bounds, an effect's kMaxEffectArcsec or kMaxEffectUm); a standard
// uncertainty also above what any reading resolves (1e-12 rad, 1e-9 mm): a smaller one would
// overflow the fit's sums.
TEST(PointsFile, PriorsAndFixedValuesOutOfTheirParametersRangeAreRefused) {
  const std::string h = kHeader;
  EXPECT_THAT(ErrorOf(h + "# prior: alpha_deg=0.02,1e200\n1 2 3\n"),
              HasSubstr("pts.txt:4: prior: the standard uncertainty of alpha: must be >= 5.72958e-11 and <= 10 deg, "
                        "got 1e200"));
  EXPECT_THAT(ErrorOf(h + "# prior: alpha_deg=0.02,1e-300\n1 2 3\n"),
              HasSubstr("the standard uncertainty of alpha: must be >= 5.72958e-11 and <= 10 deg, got 1e-300"));
  EXPECT_THAT(ErrorOf(h + "# prior: alpha_deg=20,0.1\n1 2 3\n"),
              HasSubstr("pts.txt:4: prior: alpha: must be >= -10 and <= 10 deg, got 20"));
  EXPECT_THAT(ErrorOf(h + "# prior: theta_encoder.c2_arcsec=5,5000\n1 2 3\n"),
              HasSubstr("the standard uncertainty of theta_encoder.c2: must be >= 2.06265e-07 and <= 3600 arcsec"));
  EXPECT_THAT(ErrorOf(h + "# prior: d_prime_um=-62,1e-7\n1 2 3\n"),
              HasSubstr("the standard uncertainty of d_prime: must be >= 1e-06 and <= 100000 um, got 1e-7"));
  EXPECT_THAT(ErrorOf(h + "# fix: probe_gain.u1_um=2000\n1 2 3\n"),
              HasSubstr("pts.txt:4: fix: probe_gain.u1: must be >= -1000 and <= 1000 um, got 2000"));
  const PointsData ok = Parse("# prior: alpha_deg=0.02,1e-6 d_prime_um=-62,0.001\n1 2 3\n");
  ASSERT_EQ(ParameterPriorsOf(ok.header).size(), 2u);
}

// A field of the whole file with a setup's suffix would be kept as metadata and state nothing: it
// is refused at its line, before the samples and between them.
TEST(PointsFile, AFieldOfTheWholeFileWithASetupSuffixIsRefused) {
  const std::string h = kHeader;
  EXPECT_THAT(ErrorOf(h + "# fix@0: alpha\n1 2 3\n"),
              HasSubstr("pts.txt:4: header key 'fix@0': fix belongs to the whole file and takes no setup suffix (@0); "
                        "only mount_rotation_deg and sphere_radius_mm are given per setup"));
  EXPECT_THAT(ErrorOf(h + "# sphere_form_rms_um@0: 0.02\n1 2 3\n"),
              HasSubstr("pts.txt:4: header key 'sphere_form_rms_um@0': sphere_form_rms_um belongs to the whole file"));
  EXPECT_THAT(ErrorOf(h + "# prior@1: alpha_deg=0.02,0.001\n1 2 3\n"), HasSubstr("header key 'prior@1'"));
  EXPECT_THAT(ErrorOf(h + "# probe_offset_mm@2: 25\n1 2 3\n"), HasSubstr("header key 'probe_offset_mm@2'"));
  EXPECT_THAT(ErrorOf(h + "1 2 3\n# fix@0: alpha\n4 5 6\n"), HasSubstr("pts.txt:5: header key 'fix@0'"));
  // Metadata of the lab's own with a suffix stays metadata.
  const PointsData d = Parse("# operator@site: A. N. Other\n1 2 3\n");
  ASSERT_EQ(d.header.metadata.size(), 1u);
  EXPECT_EQ(d.header.metadata[0].first, "operator@site");
}

TEST(PointsFile, DefaultColumnsAndRowIndexAsTime) {
  const PointsData d = Parse("1 2 3\n4 5 6\n");
  EXPECT_FALSE(d.header.sphere_radius_mm.has_value());
  EXPECT_FALSE(d.has_time);
  EXPECT_FALSE(d.has_setup);
  ASSERT_EQ(d.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(d.samples[1].t_s, 1.0);
  EXPECT_EQ(d.samples[1].setup, 0);
}

TEST(PointsFile, ColumnsInAnyOrder) {
  const PointsData d = Parse("# columns: r_mm setup phi_deg theta_deg\n5.5 2 30 60\n");
  EXPECT_DOUBLE_EQ(d.samples[0].r_mm, 5.5);
  EXPECT_EQ(d.samples[0].setup, 2);
  EXPECT_DOUBLE_EQ(d.samples[0].phi_deg, 30.0);
  EXPECT_DOUBLE_EQ(d.samples[0].theta_deg, 60.0);
}

TEST(PointsFile, WriteThenReadRoundTrips) {
  PointsData d;
  d.header.sphere_radius_mm = 12.7;
  d.header.probe_offset_mm = 25.0;
  d.header.metadata = {{"sphere", "G3 ball #17"}};
  d.has_time = d.has_setup = true;
  d.samples = {{1.25, 7.5, 5.0912345678, 0.5, 0}, {359.9, 172.5, 4.0000000001, 1.0, 1}};
  std::ostringstream out;
  WritePoints(out, d);
  const PointsData back = Parse(out.str());
  EXPECT_EQ(back.header.metadata, d.header.metadata);
  EXPECT_DOUBLE_EQ(*back.header.sphere_radius_mm, 12.7);
  ASSERT_EQ(back.samples.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(back.samples[i].theta_deg, d.samples[i].theta_deg, 1e-10);
    EXPECT_NEAR(back.samples[i].r_mm, d.samples[i].r_mm, 1e-10);
    EXPECT_EQ(back.samples[i].setup, d.samples[i].setup);
  }
}

// The largest finite values take 320 characters each in fixed point: rows of any length are
// written whole and read back exactly.
TEST(PointsFile, WritesTheLargestFiniteValuesWhole) {
  // Values at the reader's bounds (kMaxAngleDeg, kMaxReadingMm, kMaxTimeS) come back exactly.
  PointsData d;
  d.has_time = d.has_setup = true;
  d.samples = {{-kMaxAngleDeg, std::nextafter(kMaxAngleDeg, 0.0), -kMaxReadingMm, -kMaxTimeS,
                std::numeric_limits<int>::min()},
               {1.5, 2.5, std::nextafter(kMaxReadingMm, 0.0), 4.5, 1}};
  std::ostringstream out;
  WritePoints(out, d);
  const PointsData back = Parse(out.str());
  ASSERT_EQ(back.samples.size(), 2u);
  EXPECT_EQ(back.samples[0].theta_deg, -kMaxAngleDeg);
  EXPECT_EQ(back.samples[0].phi_deg, std::nextafter(kMaxAngleDeg, 0.0));
  EXPECT_EQ(back.samples[0].r_mm, -kMaxReadingMm);
  EXPECT_EQ(back.samples[0].t_s, -kMaxTimeS);
  EXPECT_EQ(back.samples[0].setup, std::numeric_limits<int>::min());
  EXPECT_EQ(back.samples[1].r_mm, std::nextafter(kMaxReadingMm, 0.0));
  EXPECT_EQ(back.samples[1].t_s, 4.5);

  // The largest finite double is written whole (no overflow to inf, no rounding), for the reader to refuse.
  constexpr double kMax = std::numeric_limits<double>::max();
  d.samples = {{-kMax, kMax, -kMax, 0.0, 0}};
  std::ostringstream big;
  WritePoints(big, d);
  std::string last = big.str();
  last.pop_back();
  std::istringstream row(last.substr(last.rfind('\n') + 1));
  std::string theta, phi, r;
  row >> theta >> phi >> r;
  EXPECT_EQ(std::strtod(theta.c_str(), nullptr), -kMax);
  EXPECT_EQ(std::strtod(phi.c_str(), nullptr), kMax);
  EXPECT_EQ(std::strtod(r.c_str(), nullptr), -kMax);
  EXPECT_THAT(ErrorOf(big.str()), HasSubstr("column theta_deg: '-179769313486231570814527423731704356798"));
}

TEST(PointsFile, ErrorsNameFileLineAndProblem) {
  EXPECT_THAT(ErrorOf(std::string(kHeader) + "1 2\n"),
              HasSubstr("pts.txt:4: expected 3 columns (theta_deg phi_deg r_mm), found 2"));
  EXPECT_THAT(ErrorOf("1 2 x5\n"), HasSubstr("pts.txt:1: column r_mm: 'x5' is not a number"));
  EXPECT_THAT(ErrorOf("1 2 3\n1 nan 3\n"), HasSubstr("pts.txt:2: column phi_deg: 'nan' is not a finite number"));
  EXPECT_THAT(ErrorOf("inf 2 3\n"), HasSubstr("pts.txt:1: column theta_deg: 'inf' is not a finite number"));
  // A bad columns line is named at its own line, not at the first sample.
  EXPECT_THAT(ErrorOf("# sph-points 1\n# columns: theta_deg phi_deg r_mm time\n1 2 3 4\n"),
              HasSubstr("pts.txt:2: unknown column name 'time'"));
  EXPECT_THAT(ErrorOf("# columns: theta_deg phi_deg r_mm r_mm\n1 2 3 4\n"), HasSubstr("column 'r_mm' is named twice"));
  EXPECT_THAT(ErrorOf("# columns: theta_deg phi_deg\n1 2\n"), HasSubstr("required column 'r_mm' is missing"));
  EXPECT_THAT(ErrorOf("# sphere_radius_mm: 20\n# sphere_radius_mm: 21\n1 2 3\n"),
              HasSubstr("pts.txt:2: header key 'sphere_radius_mm' is given twice"));
  EXPECT_THAT(ErrorOf("# sphere_radius_mm: -3\n1 2 3\n"), HasSubstr("pts.txt:1: sphere_radius_mm must be positive"));
  EXPECT_THAT(ErrorOf("# probe_offset_mm: 0\n1 2 3\n"), HasSubstr("pts.txt:1: probe_offset_mm must be positive"));
  EXPECT_THAT(ErrorOf("# sphere_radius_mm: twenty\n1 2 3\n"), HasSubstr("'twenty' is not a number"));
  EXPECT_THAT(ErrorOf(kHeader), HasSubstr("pts.txt: no samples"));
  EXPECT_THAT(ErrorOf(""), HasSubstr("pts.txt: no samples"));
  EXPECT_THAT(ErrorOf("# sph-points 2\n1 2 3\n"), HasSubstr("pts.txt:1: format 'sph-points 2' is not supported"));
  EXPECT_THAT(ErrorOf("# columns: theta_deg phi_deg r_mm setup\n1 2 3 1.5\n"),
              HasSubstr("column setup: '1.5' is not an integer"));
  EXPECT_THAT(ErrorOf(std::string("1 2 3\n\0\x01\x02 4\n", 13)), HasSubstr("pts.txt:2: binary data"));
  EXPECT_THAT(ErrorOf("# columns: theta_deg phi_deg r_mm setup\n1 2 3 99999999999\n"),
              HasSubstr("pts.txt:2: column setup: '99999999999' is out of the range of an integer (-2147483648 to "
                        "2147483647)"));
  EXPECT_THAT(ErrorOf("1 2 3\n1 2 1e999\n"),
              HasSubstr("pts.txt:2: column r_mm: '1e999' is out of the range of a double"));
}

TEST(PointsFile, ALongFieldIsCutInTheMessage) {
  const std::string field(1 << 19, '7');  // within a line's bound (kMaxLineBytes)
  const std::string message = ErrorOf("1 2 3x" + field + "\n");
  EXPECT_THAT(message, HasSubstr("pts.txt:1: column r_mm: '3x" + field.substr(0, 38) +
                                 "...' (524290 characters) is "
                                 "not a number"));
  EXPECT_LT(message.size(), 200u);
}

TEST(PointsFile, AUtf8ByteOrderMarkIsSkipped) {
  const PointsData d = Parse("\xEF\xBB\xBF# sph-points 1\n# sphere_radius_mm: 20\n1 2 3\n");
  EXPECT_EQ(d.header.sphere_radius_mm, 20.0);
  ASSERT_EQ(d.samples.size(), 1u);
  EXPECT_EQ(d.sample_lines, std::vector<long>{3});
}

TEST(PointsFile, ADirectoryIsNamedAsOne) {
  const std::string dir = sph::testing::MakeTempDir("points_dir");
  try {
    ReadPointsFile(dir);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(dir + ": is a directory, not a file"));
  }
}

TEST(PointsFile, AnAbsurdReadingIsNamedByItsLine) {
  std::string text = std::string(kHeader) + "# columns: theta_deg phi_deg r_mm\n";
  for (int i = 0; i < 20; ++i) text += std::to_string(15 * i) + " 45 " + (i == 7 ? "1e5" : "4.9") + "\n";
  const std::vector<std::string> w = PlausibilityWarnings(Parse(text));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_THAT(w[0], HasSubstr("1 probe reading(s) lie farther from the median reading (4.9 mm) than the sphere's "
                              "diameter (40 mm)"));
  EXPECT_THAT(w[0], HasSubstr("pts.txt:12: r_mm 100000"));
}

TEST(PointsFile, MissingFileIsAnError) {
  try {
    ReadPointsFile("/nonexistent/points.txt");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/points.txt: cannot open for reading"));
  }
}

TEST(PlausibilityWarnings, RadiansInADegreeColumnAndRepeatedRows) {
  std::string text = "# columns: theta_deg phi_deg r_mm\n";
  for (int i = 0; i < 24; ++i) text += std::to_string(0.2618 * i) + " 1.5708 5.0\n";  // 15 deg steps, in rad
  std::istringstream rad(text);
  const std::vector<std::string> w = PlausibilityWarnings(ParsePoints(rad, "rad.txt"));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_THAT(w[0], HasSubstr("rad.txt: theta_deg spans only 0..6.021"));
  EXPECT_THAT(w[0], HasSubstr("are the angles in radians?"));

  std::string deg = "# columns: theta_deg phi_deg r_mm\n";
  for (int i = 0; i < 24; ++i) deg += std::to_string(15 * i) + " 90 5.0\n";
  deg += "30 90 5.0\n";  // sample 25 repeats sample 3
  std::istringstream in(deg);
  const std::vector<std::string> d = PlausibilityWarnings(ParsePoints(in, "deg.txt"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_THAT(d[0], HasSubstr("deg.txt: 1 sample(s) repeat an earlier one exactly (the first: sample 25)"));
}

// ---- mount rotations: "# mount_rotation_deg@<setup>: rx ry rz" or "unknown" -------------------------

constexpr const char* kTwoSetups = "# columns: theta_deg phi_deg r_mm setup\n0 7.5 5.1 0\n15 7.5 5.2 1\n";

TEST(PointsFile, ReadsMountRotationsPerSetup) {
  const PointsData d = Parse(std::string(kHeader) +
                             "# mount_rotation_deg@1: 0 0 90\n# mount_rotation_deg@-2: unknown\n"
                             "# mount_rotation_deg@+0:  0.5\t-1e-3 +180 \n# operator@1: B. Jones\n"
                             "# columns: theta_deg phi_deg r_mm setup\n0 7.5 5.1 0\n15 7.5 5.2 1\n30 7.5 5.3 -2\n");
  ASSERT_EQ(d.header.mount_rotations.size(), 3u);
  EXPECT_EQ(d.header.mount_rotations.at(1), MountRotation::Known(Eigen::Vector3d(0, 0, 90)));
  EXPECT_EQ(d.header.mount_rotations.at(0), MountRotation::Known(Eigen::Vector3d(0.5, -1e-3, 180)));
  EXPECT_FALSE(d.header.mount_rotations.at(-2).known());
  // Other per-setup keys are kept as metadata, as any other key.
  ASSERT_EQ(d.header.metadata.size(), 1u);
  EXPECT_EQ(d.header.metadata[0], (std::pair<std::string, std::string>("operator@1", "B. Jones")));
  // Without the key a setup holds the sphere in the reference orientation: no entry.
  EXPECT_TRUE(Parse(kTwoSetups).header.mount_rotations.empty());
  // A file without a setup column has setup 0.
  EXPECT_TRUE(Parse("# mount_rotation_deg@0: 1 2 3\n1 2 3\n").header.mount_rotations.at(0).known());
  // Prose with a colon is still prose.
  EXPECT_TRUE(Parse("# see mount_rotation_deg@1 below: nothing\n1 2 3\n").header.mount_rotations.empty());
}

TEST(PointsFile, BadMountRotationsAreNamedByFileLineAndProblem) {
  const std::string h = kHeader;  // 3 lines
  const auto with = [&](const std::string& field) { return h + "# " + field + "\n" + kTwoSetups; };
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0 x 90")),
              HasSubstr("pts.txt:4: mount_rotation_deg@1 ry: 'x' is not a number"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0 0 nan")),
              HasSubstr("pts.txt:4: mount_rotation_deg@1 rz: 'nan' is not a finite number"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0 90")),
              HasSubstr("pts.txt:4: mount_rotation_deg@1: expected 'rx ry rz' (a rotation vector in deg, axis times "
                        "angle) or 'unknown', found 2 values"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0,0,90")), HasSubstr("pts.txt:4: mount_rotation_deg@1: expected "));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0 0 90 1")), HasSubstr("found 4 values"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1:")), HasSubstr("found 0 values"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: Unknown")), HasSubstr("found 1 value"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@x: 0 0 90")),
              HasSubstr("pts.txt:4: mount_rotation_deg@x: setup id: 'x' is not an integer"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1.5: 0 0 90")),
              HasSubstr("pts.txt:4: mount_rotation_deg@1.5: setup id: '1.5' is not an integer"));
  EXPECT_THAT(
      ErrorOf(with("mount_rotation_deg: 0 0 90")),
      HasSubstr("pts.txt:4: mount_rotation_deg belongs to one setup: write 'mount_rotation_deg@<setup>: rx ry rz'"));
  EXPECT_THAT(ErrorOf(h + "# mount_rotation_deg@1: 0 0 90\n# mount_rotation_deg@1: 0 0 90\n" + kTwoSetups),
              HasSubstr("pts.txt:5: header key 'mount_rotation_deg@1' is given twice"));
  EXPECT_THAT(ErrorOf(h + "# mount_rotation_deg@1: 0 0 90\n# mount_rotation_deg@01: unknown\n" + kTwoSetups),
              HasSubstr("pts.txt:5: the mount rotation of setup 1 is given twice (first at line 4)"));
  // A setup without samples is found after reading, and named at its header line.
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@5: 0 0 90")),
              HasSubstr("pts.txt:4: mount_rotation_deg@5: setup 5 has no samples (the file's setups: 0 1)"));
  EXPECT_THAT(ErrorOf("# mount_rotation_deg@1: unknown\n1 2 3\n"),
              HasSubstr("pts.txt:1: mount_rotation_deg@1: setup 1 has no samples (the file has no setup column: all "
                        "its samples are setup 0)"));
}

TEST(PointsFile, MountRotationsRoundTripExactly) {
  PointsData d;
  d.has_setup = true;
  d.samples = {{1, 2, 3, 0, 0}, {1, 2, 3, 1, 1}, {1, 2, 3, 2, 7}};
  d.header.mount_rotations = {{0, MountRotation::Known(Eigen::Vector3d(0.1, 1.0 / 3.0, -1e-300))},
                              {1, MountRotation::Unknown()},
                              {7, MountRotation::Known(Eigen::Vector3d(0, -0.0, 359.99999999999994))}};
  std::ostringstream out;
  WritePoints(out, d);
  EXPECT_THAT(out.str(),
              HasSubstr("# mount_rotation_deg@0: 0.1 0.3333333333333333 -1e-300\n"
                        "# mount_rotation_deg@1: unknown\n# mount_rotation_deg@7: 0 -0 359.99999999999994\n"));
  const PointsData back = Parse(out.str());
  EXPECT_EQ(back.header.mount_rotations, d.header.mount_rotations);
}

// ---- another sphere in a setup: "# sphere_radius_mm@<setup>: R" ------------------------------------

TEST(PointsFile, ReadsTheRadiusOfAnotherSpherePerSetup) {
  const PointsData d = Parse(std::string(kHeader) + "# sphere_radius_mm@1:  12.5 \n" + kTwoSetups +
                             "# sphere_radius_mm@2: 6\n30 7.5 5.3 2\n");  // a setup a later run appended
  EXPECT_EQ(*d.header.sphere_radius_mm, 20.0);                            // the reference sphere's R0 stays apart
  EXPECT_EQ(d.header.sphere_radii_mm, (std::map<int, double>{{1, 12.5}, {2, 6.0}}));
  EXPECT_TRUE(Parse(kTwoSetups).header.sphere_radii_mm.empty());
  // Which form each setup sees: the reference sphere's, another sphere's (shared by the setups that
  // give its radius), or one of its own at an unknown orientation.
  const PointsData f = Parse(
      "# sphere_radius_mm@1: 10\n# sphere_radius_mm@2: 10.0\n# sphere_radius_mm@3: 12\n# sphere_radius_mm@4: 10\n"
      "# mount_rotation_deg@0: 0 0 90\n# mount_rotation_deg@2: 90 0 0\n# mount_rotation_deg@4: unknown\n"
      "# columns: theta_deg phi_deg r_mm setup\n0 7.5 5.1 0\n0 7.5 5.1 1\n0 7.5 5.1 2\n0 7.5 5.1 3\n0 7.5 5.1 4\n");
  EXPECT_EQ(f.header.FormKey(0), "");
  EXPECT_EQ(f.header.FormKey(1), "sphere_radius_mm 10");
  EXPECT_EQ(f.header.FormKey(2), f.header.FormKey(1));
  EXPECT_EQ(f.header.FormKey(3), "sphere_radius_mm 12");
  EXPECT_EQ(f.header.FormKey(4), "unknown@4");
}

TEST(PointsFile, BadRadiiOfSetupsAreNamedByFileLineAndProblem) {
  const std::string h = kHeader;  // 3 lines
  const auto with = [&](const std::string& field) { return h + "# " + field + "\n" + kTwoSetups; };
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@1: ten")),
              HasSubstr("pts.txt:4: sphere_radius_mm@1: 'ten' is not a number"));
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@1: 0")), HasSubstr("pts.txt:4: sphere_radius_mm@1 must be positive"));
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@1: -5")), HasSubstr("pts.txt:4: sphere_radius_mm@1 must be positive"));
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@1: 1e6")),
              HasSubstr("pts.txt:4: sphere_radius_mm@1 must be at most 1000 mm, got '1e6'"));
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@1: 10 12")), HasSubstr("pts.txt:4: sphere_radius_mm@1: "));
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@one: 10")),
              HasSubstr("pts.txt:4: sphere_radius_mm@one: setup id: 'one' is not an integer"));
  EXPECT_THAT(ErrorOf(with("sphere_radius_mm@3: 10")),
              HasSubstr("pts.txt:4: sphere_radius_mm@3: setup 3 has no samples (the file's setups: 0 1)"));
  EXPECT_THAT(ErrorOf(h + "# sphere_radius_mm@1: 10\n# sphere_radius_mm@01: 10\n" + kTwoSetups),
              HasSubstr("pts.txt:5: the sphere radius of setup 1 is given twice (first at line 4)"));
  // The mount rotation and the radius of one setup are two fields.
  EXPECT_EQ(ErrorOf(h + "# sphere_radius_mm@1: 10\n# mount_rotation_deg@1: 0 0 90\n" + kTwoSetups), "");
}

TEST(PointsFile, RadiiOfSetupsRoundTripExactly) {
  PointsData d;
  d.has_setup = true;
  d.header.sphere_radius_mm = 20.0;
  d.samples = {{1, 2, 3, 0, 0}, {1, 2, 3, 1, 1}, {1, 2, 3, 2, 4}};
  d.header.sphere_radii_mm = {{1, 1.0 / 3.0}, {4, 12.7}};
  std::ostringstream out;
  WritePoints(out, d);
  EXPECT_THAT(out.str(), HasSubstr("# sphere_radius_mm@1: 0.3333333333333333\n# sphere_radius_mm@4: 12.7\n"));
  EXPECT_EQ(Parse(out.str()).header.sphere_radii_mm, d.header.sphere_radii_mm);
}

TEST(IsHeaderKey, NamesAndPerSetupNames) {
  // A key with '@' and no setup id is a key: the reader refuses it for the keys it knows, where a
  // comment would hide it.
  for (const char* key : {"sphere_radius_mm", "operator", "x-y", "mount_rotation_deg@1", "a@x", "a@-1", "a@"}) {
    EXPECT_TRUE(IsHeaderKey(key)) << key;
  }
  for (const char* key : {"", "@1", "a b", "a@1 2", "a.b", "mount rotation@1"}) EXPECT_FALSE(IsHeaderKey(key)) << key;
}

// ---- fields that would apply to rows recorded before them -------------------------------------------

TEST(PointsFile, ASetupFieldAfterARowOfItsSetupIsRefused) {
  const std::string h = kHeader;  // 3 lines; kTwoSetups: the columns at line 4, rows of setups 0 and 1 at 5 and 6
  EXPECT_EQ(ErrorOf(h + kTwoSetups + "# mount_rotation_deg@0: 0 0 90\n"),
            "pts.txt:7: mount_rotation_deg@0: setup 0 has rows before this line (the first at line 5): the mount "
            "rotation of a setup applies to all of its rows and stands before the first of them");
  EXPECT_EQ(ErrorOf(h + kTwoSetups + "# sphere_radius_mm@1: 10\n15 7.5 5.2 1\n"),
            "pts.txt:7: sphere_radius_mm@1: setup 1 has rows before this line (the first at line 6): the sphere "
            "radius of a setup applies to all of its rows and stands before the first of them");
  // Between samples, before the first row of its setup: where an appending run writes a new setup's.
  const PointsData d =
      Parse(h + kTwoSetups + "# mount_rotation_deg@2: 0 90 0\n# sphere_radius_mm@2: 10\n30 7.5 5.3 2\n");
  EXPECT_EQ(d.header.mount_rotations.at(2), MountRotation::Known(Eigen::Vector3d(0, 90, 0)));
  EXPECT_EQ(d.header.sphere_radii_mm.at(2), 10.0);
  // Without a setup column every row is setup 0.
  EXPECT_THAT(ErrorOf("1 2 3\n# mount_rotation_deg@0: unknown\n"),
              HasSubstr("pts.txt:2: mount_rotation_deg@0: setup 0 has rows before this line (the first at line 1)"));
}

TEST(PointsFile, AColumnsLineOrAHeaderFieldAfterTheFirstSampleIsRefused) {
  const std::string h = std::string(kHeader) + "0 7.5 5.1\n15 7.5 5.2\n";  // rows at lines 4 and 5
  EXPECT_EQ(ErrorOf(h + "# columns: theta_deg phi_deg r_mm t_s\n30 7.5 5.3 2\n"),
            "pts.txt:6: a columns line after the first sample (line 4): the columns are named once, before the "
            "samples, and the rows above were read without it");
  EXPECT_EQ(ErrorOf(h + "# probe_offset_mm: 30\n"),
            "pts.txt:6: header field 'probe_offset_mm' after the first sample (line 4): header fields stand before "
            "the samples");
  EXPECT_THAT(ErrorOf(h + "#sphere_temperature_c: 21\n"),
              HasSubstr("pts.txt:6: header field 'sphere_temperature_c' after the first sample"));
  // Other comments between samples, "key: value" ones too, are comments.
  EXPECT_EQ(Parse(h + "# stop: 3\n# resumed at: 12:00\n30 7.5 5.3\n").samples.size(), 3u);
}

// ---- bounds ---------------------------------------------------------------------------------------

TEST(PointsFile, MountRotationsAreBoundedAsTheOptionsAre) {
  const std::string h = kHeader;
  const auto with = [&](const std::string& field) { return h + "# " + field + "\n" + kTwoSetups; };
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0 0 360000")),
              HasSubstr("pts.txt:4: mount_rotation_deg@1 rz: must be within [-360, 360] deg, got '360000'"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 1e10 0 0")),
              HasSubstr("pts.txt:4: mount_rotation_deg@1 rx: must be within [-360, 360] deg, got '1e10'"));
  EXPECT_THAT(ErrorOf(with("mount_rotation_deg@1: 0 -1e308 0")), HasSubstr("mount_rotation_deg@1 ry: must be within"));
  EXPECT_EQ(Parse(with("mount_rotation_deg@1: -360 0 360")).header.mount_rotations.at(1),
            MountRotation::Known(Eigen::Vector3d(-360, 0, 360)));
}

TEST(PointsFile, ASetupFieldThatNamesNoSetupIsRefused) {
  const std::string h = kHeader;
  EXPECT_EQ(ErrorOf(h + "# mount_rotation_deg@: 0 0 90\n" + kTwoSetups),
            "pts.txt:4: mount_rotation_deg@ names no setup: write 'mount_rotation_deg@<setup>: rx ry rz'");
  EXPECT_EQ(ErrorOf(h + "# sphere_radius_mm@: -10\n" + kTwoSetups),
            "pts.txt:4: sphere_radius_mm@ names no setup: write 'sphere_radius_mm@<setup>: R'");
  // Between samples too (a key with a space in it is prose).
  EXPECT_EQ(ErrorOf(h + kTwoSetups + "# sphere_radius_mm @: 10\n# mount_rotation_deg@ : 0 0 90\n"),
            "pts.txt:8: mount_rotation_deg@ names no setup: write 'mount_rotation_deg@<setup>: rx ry rz'");
}

TEST(PointsFile, AnglesAndReadingsAreBounded) {
  const std::string h = std::string(kHeader) + "0 7.5 5.1\n";
  EXPECT_EQ(ErrorOf(h + "15 7.5 1e150\n"),
            "pts.txt:5: column r_mm: '1e150' is beyond 1e+06 mm from 0: not a probe reading in mm");
  EXPECT_THAT(ErrorOf(h + "15 7.5 -1000001\n"), HasSubstr("pts.txt:5: column r_mm: '-1000001' is beyond"));
  EXPECT_EQ(ErrorOf(h + "1e10 7.5 5.2\n"),
            "pts.txt:5: column theta_deg: '1e10' is beyond 1e+09 deg from 0: not an encoder's angle");
  EXPECT_THAT(ErrorOf(h + "15 -2e9 5.2\n"), HasSubstr("pts.txt:5: column phi_deg: '-2e9' is beyond 1e+09 deg"));
  const PointsData d = Parse(h + "-1e9 1e9 1e6\n15 7.5 -1e6\n");
  EXPECT_EQ(d.samples[1].theta_deg, -1e9);
  EXPECT_EQ(d.samples[1].phi_deg, 1e9);
  EXPECT_EQ(d.samples[1].r_mm, 1e6);
  EXPECT_EQ(d.samples[2].r_mm, -1e6);
}

TEST(PointsFile, TimesAreBounded) {
  const std::string h = std::string(kHeader) + "# columns: theta_deg phi_deg r_mm t_s\n0 7.5 5.1 0\n";
  EXPECT_EQ(ErrorOf(h + "15 7.5 5.2 1e308\n"),
            "pts.txt:6: column t_s: '1e308' is beyond 1e+12 s from 0: not a time of a measurement");
  EXPECT_THAT(ErrorOf(h + "15 7.5 5.2 -1e308\n"), HasSubstr("pts.txt:6: column t_s: '-1e308' is beyond 1e+12 s"));
  EXPECT_THAT(ErrorOf(h + "15 7.5 5.2 1.0000001e12\n"), HasSubstr("pts.txt:6: column t_s: '1.0000001e12' is beyond"));
  const PointsData d = Parse(h + "15 7.5 5.2 -1e12\n30 7.5 5.3 1e12\n45 7.5 5.4 1700000000.123456\n");
  EXPECT_EQ(d.samples[1].t_s, -1e12);
  EXPECT_EQ(d.samples[2].t_s, 1e12);
}

// /dev/zero, or a file without line breaks, costs a line's bound at most.
TEST(PointsFile, ANulOrAnEndlessLineIsRefusedAfterABoundedRead) {
  sph::testing::RepeatedBytes zeros('\0', std::size_t{64} << 20);
  std::istream z(&zeros);
  try {
    ParsePoints(z, "zero");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "zero:1: binary data (NUL byte): this is not a points file");
  }
  EXPECT_LE(zeros.consumed(), 8192u);
  sph::testing::RepeatedBytes digits('7', std::size_t{64} << 20);
  std::istream d(&digits);
  try {
    ParsePoints(d, "digits");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "digits:1: the line is longer than 1048576 bytes: this is not a points file");
  }
  EXPECT_LE(digits.consumed(), kMaxLineBytes + 8192);
  // A NUL after a long run of text on its line is found where it is read.
  std::string text = "# sph-points 1\n0 7.5 " + std::string(100000, '5');
  text += '\0';
  EXPECT_EQ(ErrorOf(text + "\n"), "pts.txt:2: binary data (NUL byte): this is not a points file");
  // The longest line is read whole, with or without its line break.
  EXPECT_EQ(Parse("# " + std::string(kMaxLineBytes - 2, 'c') + "\n1 2 3").samples.size(), 1u);
  EXPECT_EQ(Parse("1 2 3\n#" + std::string(kMaxLineBytes - 1, 'c')).samples.size(), 1u);
}

// ---- orientations compared as rotations --------------------------------------------------------------

TEST(SameOrientation, ComparesRotationsNotNumbers) {
  const auto known = [](double x, double y, double z) { return MountRotation::Known(Eigen::Vector3d(x, y, z)); };
  EXPECT_TRUE(SameOrientation(known(0, -270, 0), known(0, 90, 0)));
  EXPECT_TRUE(SameOrientation(known(0, 0, 0), known(0, 0, 360)));
  EXPECT_TRUE(SameOrientation(known(180, 0, 0), known(-180, 0, 0)));
  EXPECT_TRUE(SameOrientation(known(0, 0, 90), known(0, 0, 90 + 0.5e-6)));
  EXPECT_FALSE(SameOrientation(known(0, 0, 90), known(0, 0, 90 + 2e-6)));
  EXPECT_FALSE(SameOrientation(known(90, 0, 0), known(0, 90, 0)));
  EXPECT_FALSE(SameOrientation(known(0, 0, 90), known(0, 0, -90)));
  EXPECT_TRUE(SameOrientation(MountRotation::Unknown(), MountRotation::Unknown()));
  EXPECT_FALSE(SameOrientation(MountRotation::Unknown(), known(0, 0, 0)));
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

TEST(DevicesOf, ReadsTheIdentityLinesOfTheHeaderAsTheDaemonWritesThem) {
  const std::vector<std::pair<std::string, std::string>> metadata = {
      {"generator", "sph_acquired 1.0"},
      {"device_phi_encoder",
       "node 2; name \"sph_cansim phi encoder\"; vendor_id 0x00535048; product_code 0x00004061; revision 0x00010000; "
       "serial 0x00010002; total_measuring_range 4096; tpdo 1 cob_id 0x182"},
      {"device_", "node 9"},            // no role: not a device
      {"device_probe", "node 3; odd"},  // an item that is no "key value" is kept as written
  };
  const std::vector<HeaderDevice> d = DevicesOf(metadata);
  ASSERT_EQ(d.size(), 2U);
  EXPECT_EQ(d[0].role, "phi_encoder");
  EXPECT_EQ(d[0].node, "2");
  EXPECT_EQ(d[0].name, "sph_cansim phi encoder");
  EXPECT_EQ(d[0].vendor_id, "0x00535048");
  EXPECT_EQ(d[0].product_code, "0x00004061");
  EXPECT_EQ(d[0].revision, "0x00010000");
  EXPECT_EQ(d[0].serial, "0x00010002");
  EXPECT_EQ(d[0].other, (std::vector<std::string>{"total_measuring_range 4096", "tpdo 1 cob_id 0x182"}));
  EXPECT_EQ(d[1].role, "probe");
  EXPECT_EQ(d[1].node, "3");
  EXPECT_TRUE(d[1].name.empty());
  EXPECT_EQ(d[1].other, (std::vector<std::string>{"odd"}));
}

TEST(Utf8CharLength, TakesWellFormedUtf8Only) {
  EXPECT_EQ(Utf8CharLength("a"), 1u);
  EXPECT_EQ(Utf8CharLength("\xC3\xA9"), 2u);          // e acute
  EXPECT_EQ(Utf8CharLength("\xE2\x82\xAC"), 3u);      // the euro sign
  EXPECT_EQ(Utf8CharLength("\xF0\x9F\x98\x80"), 4u);  // an emoji
  EXPECT_EQ(Utf8CharLength("\xE9"), 0u);              // Latin-1 e acute
  EXPECT_EQ(Utf8CharLength("\xA9"), 0u);              // a stray continuation byte
  EXPECT_EQ(Utf8CharLength("\xC0\xAF"), 0u);          // an overlong '/'
  EXPECT_EQ(Utf8CharLength("\xE0\x80\xAF"), 0u);      // another
  EXPECT_EQ(Utf8CharLength("\xED\xA0\x80"), 0u);      // a surrogate
  EXPECT_EQ(Utf8CharLength("\xF4\x90\x80\x80"), 0u);  // beyond U+10FFFF
  EXPECT_EQ(Utf8CharLength("\xE2\x82"), 0u);          // cut short
  EXPECT_EQ(FirstNonUtf8("caf\xC3\xA9 ok"), std::string::npos);
  EXPECT_EQ(FirstNonUtf8("caf\xE9"), 3u);
}

TEST(PointsFile, HeaderTextThatIsNotUtf8IsRefusedAtItsLine) {
  EXPECT_EQ(ErrorOf(std::string(kHeader) + "# operator: caf\xE9\n0 7.5 4.8\n"),
            "pts.txt:4: operator: 'caf\\xE9' is not UTF-8 text (the byte 0xE9 at character 4): save the file as "
            "UTF-8, for the reports copy the header's text");
  EXPECT_THAT(ErrorOf(std::string(kHeader) + "# op@caf\xE9: x\n0 7.5 4.8\n"),
              HasSubstr("pts.txt:4: header key 'op@caf\\xE9' is not UTF-8 text"));
  const PointsData p = Parse(std::string(kHeader) + "# operator: caf\xC3\xA9 \x1b[2J\n0 7.5 4.8\n");
  ASSERT_EQ(p.header.metadata.size(), 1u);
  EXPECT_EQ(p.header.metadata[0].second, "caf\xC3\xA9 \x1b[2J");  // kept as the bytes it is
  // A comment line is no field: its text goes nowhere.
  EXPECT_NO_THROW(Parse(std::string(kHeader) + "# caf\xE9 without a colon\n0 7.5 4.8\n"));
}

TEST(PointsFile, AHeaderValueWithACarriageReturnInsideIsRefusedAtItsLine) {
  // A writer could not write it back as one line: refused where it is read.
  const std::string e = ErrorOf(std::string(kHeader) + "# operator: 12\r.7\n0 7.5 4.8\n");
  EXPECT_THAT(e, HasSubstr("pts.txt:4: operator: "));
  EXPECT_THAT(e, HasSubstr("holds a carriage return: a header field is one line"));
  // A line's end in CR LF is a line's end.
  const PointsData p = Parse(std::string(kHeader) + "# operator: bob\r\n0 7.5 4.8\r\n");
  ASSERT_EQ(p.header.metadata.size(), 1u);
  EXPECT_EQ(p.header.metadata[0].second, "bob");
}

TEST(PointsFile, ARowWithCommasSaysSo) {
  EXPECT_EQ(ErrorOf(std::string(kHeader) + "0,7.5,4.8\n"),
            "pts.txt:4: expected 3 columns (theta_deg phi_deg r_mm), found 1 (the line holds commas: a points file "
            "separates its values by spaces or tabs, and a decimal point is '.')");
  EXPECT_EQ(ErrorOf(std::string(kHeader) + "0 7,5 4,8\n"),
            "pts.txt:4: column phi_deg: '7,5' is not a number (the line holds commas: a points file separates its "
            "values by spaces or tabs, and a decimal point is '.')");
  EXPECT_EQ(ErrorOf(std::string(kHeader) + "0 7.5\n"), "pts.txt:4: expected 3 columns (theta_deg phi_deg r_mm), found 2");
}

TEST(PointsFromColumns, ReadsTheHeaderAsAFileAndChecksEachReadingAsARow) {
  const double theta[] = {0.0, 90.0}, phi[] = {10.0, 20.0}, r[] = {5.0, 5.1}, setup[] = {0.0, 1.0};
  PointsColumns c;
  c.n = 2;
  c.theta_deg = theta;
  c.phi_deg = phi;
  c.r_mm = r;
  c.setup = setup;
  const PointsData p = PointsFromColumns({{"sphere_radius_mm", "20"}, {"operator", "A. Smith"}, {"columns", "x"}}, c,
                                         "mine");
  EXPECT_EQ(p.source, "mine");
  EXPECT_EQ(p.header.sphere_radius_mm, 20.0);
  EXPECT_EQ(p.header.metadata, (std::vector<std::pair<std::string, std::string>>{{"operator", "A. Smith"}}));
  ASSERT_EQ(p.samples.size(), 2u);
  EXPECT_EQ(p.samples[1].theta_deg, 90.0);
  EXPECT_EQ(p.samples[1].r_mm, 5.1);
  EXPECT_EQ(p.samples[1].t_s, 1.0);  // the row index without times
  EXPECT_EQ(p.samples[1].setup, 1);
  EXPECT_TRUE(p.has_setup);
  EXPECT_FALSE(p.has_time);
  EXPECT_TRUE(p.sample_lines.empty());
  EXPECT_EQ(p.WhereIs(1), "mine: sample 2");
  const auto error = [&](const std::vector<HeaderField>& header, const PointsColumns& columns) {
    try {
      PointsFromColumns(header, columns, "mine");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  // The header as the lines of a file: "# sph-points 1" is line 1.
  EXPECT_THAT(error({{"sphere_radius_mm", "-1"}}, c), HasSubstr("mine:2: sphere_radius_mm must be positive"));
  EXPECT_EQ(error({{"a", "1"}, {"my key!", "x"}}, c),
            "mine:3: header key 'my key!' is not a header key (a name of letters, digits, '_' and '-', then '@' and "
            "a setup id for a setup's field)");
  EXPECT_EQ(error({{"operator", "bob\n# probe_offset_mm: 30"}}, c),
            "mine:2: operator: 'bob\\x0A# probe_offset_mm: 30' holds a line break: a header field is one line (the "
            "rest would be read as lines of their own)");
  EXPECT_THAT(error({{"mount_rotation_deg@7", "0 0 90"}}, c), HasSubstr("mine:2: mount_rotation_deg@7: setup 7 has no samples"));
  const double bad_setup[] = {0.0, 0.4}, nan_r[] = {5.0, std::nan("")}, far_r[] = {5.0, 1e300};
  PointsColumns d = c;
  d.setup = bad_setup;
  EXPECT_EQ(error({}, d), "mine: sample 2: column setup: '0.4' is not an integer");
  d = c;
  d.r_mm = nan_r;
  EXPECT_EQ(error({}, d), "mine: sample 2: column r_mm: 'nan' is not a finite number");
  d.r_mm = far_r;
  EXPECT_EQ(error({}, d), "mine: sample 2: column r_mm: '1e+300' is beyond 1e+06 mm from 0: not a probe reading in mm");
  // Three columns of one (n, 3) array.
  const double rows[] = {0.0, 10.0, 5.0, 90.0, 20.0, 5.1};
  PointsColumns e;
  e.n = 2;
  e.stride = 3;
  e.theta_deg = rows;
  e.phi_deg = rows + 1;
  e.r_mm = rows + 2;
  const PointsData q = PointsFromColumns({}, e, "rows");
  EXPECT_EQ(q.samples[1].phi_deg, 20.0);
  EXPECT_EQ(q.samples[1].r_mm, 5.1);
}

TEST(WritePoints, RefusesMetadataThatAFileCouldNotHoldAsOneLine) {
  PointsData p = Parse(std::string(kHeader) + "0 7.5 4.8\n");
  p.header.metadata.emplace_back("operator", "bob\n# probe_offset_mm: 30");
  std::ostringstream out;
  EXPECT_THROW(WritePoints(out, p), Error);
  EXPECT_EQ(out.str(), "");  // nothing written
  p.header.metadata.back() = {"my key!", "x"};
  EXPECT_THROW(WritePoints(out, p), Error);
  p.header.metadata.back() = {"my_key", "x: y"};
  WritePoints(out, p);
  EXPECT_EQ(Parse(out.str()).header.metadata, p.header.metadata);
}

}  // namespace
}  // namespace sph
