#include "sph/calib/montecarlo_report.hpp"

#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace sph {
namespace {

using ::testing::HasSubstr;

int Lines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

TEST(MonteCarloReport, RendersTheStudyItsCsvAndFigure4Data) {
  MonteCarloStudyOptions spec;
  spec.trials = 3;
  spec.eccentricities_mm = {1.0, 2.0};
  spec.threads = 1;
  const MonteCarloStudy study = RunMonteCarlo(spec);
  std::ostringstream text, csv, std_dat, crlb_dat, spread_dat;
  WriteStudyTables(text, spec, study);
  EXPECT_THAT(text.str(), HasSubstr("Table 2: mean of the calibrations (3 trials per eccentricity, seed 1"));
  EXPECT_THAT(text.str(), HasSubstr("e = 2 mm: 3 of 3 converged"));
  WriteStudyCsv(csv, study);
  EXPECT_EQ(Lines(csv.str()), 1 + 2 * kNumScmsParams);  // the header, one line per eccentricity and error
  WriteFigure4Std(std_dat, study);
  EXPECT_EQ(Lines(std_dat.str()), 1 + 2);
  WriteFigure4Crlb(crlb_dat, spec, study);
  EXPECT_EQ(Lines(crlb_dat.str()), 1 + 61);
  WriteFigure4Spread(spread_dat, spec, study);
  EXPECT_EQ(Lines(spread_dat.str()), 1 + 2 * 3);  // every converged trial
  const std::string script = Figure4Script(spec, study);
  EXPECT_THAT(script, HasSubstr("set xtics (1, 2)\n"));  // one tic per eccentricity studied
  EXPECT_THAT(script, HasSubstr("set xrange [0.7:2.8]\n"));
  EXPECT_THAT(script, HasSubstr("(3 trials per point, sigma_r 0.05 um)"));
  EXPECT_THAT(script, HasSubstr("if (!exists(\"crlb_dat\")) crlb_dat = 'fig4_crlb.dat'\n"));
  const std::string json = StudyJson(spec, study, "1,0,0", 0.5, nullptr);
  EXPECT_THAT(json, HasSubstr("\"direction\": \"1,0,0\""));
  EXPECT_THAT(json, HasSubstr("\"wall_time_s\": 0.5"));
  EXPECT_THAT(json, ::testing::Not(HasSubstr("table3")));
}

TEST(MonteCarloReport, PlanPredictsWithoutSimulating) {
  MonteCarloStudyOptions spec;
  spec.eccentricities_mm = {0.0, 2.0};
  std::ostringstream text;
  const std::string json = PlanStudy(text, spec, "24 x 12 grid", 2.0, false);
  EXPECT_THAT(text.str(), HasSubstr("Predicted standard deviations (linearised at the truth, no simulation): 24 x 12 "
                                    "grid"));
  // At zero eccentricity b and c are not determined (the paper's finding); at 2 mm all seven are.
  EXPECT_THAT(text.str(), HasSubstr("e = 0 mm: undetermined: "));
  EXPECT_THAT(text.str(), ::testing::Not(HasSubstr("e = 2 mm: undetermined")));
  EXPECT_THAT(text.str(), HasSubstr("this pattern: "));
  EXPECT_THAT(text.str(), ::testing::Not(HasSubstr("other grids")));
  EXPECT_THAT(json, HasSubstr("\"target_std_um\": 2.0"));
  EXPECT_THAT(json, HasSubstr("\"smallest_eccentricity_mm\""));
}

TEST(MonteCarloReport, OrientationPlanNamesTheOrientationsThatSeparateTheForm) {
  MonteCarloStudyOptions spec;
  spec.eccentricities_mm = {2.0};
  OrientationPlanOptions options;  // the form alone beside the seven errors and the centre
  options.form_degree_max = 2;
  std::ostringstream text;
  const std::string json = PlanOrientationsReport(text, spec, options, "24 x 12 grid");
  EXPECT_THAT(text.str(), HasSubstr("separate its form (degrees 2..2) from the seven errors, the centres and no "
                                    "further effect"));
  EXPECT_THAT(text.str(), HasSubstr("24 x 12 grid in every orientation"));
  EXPECT_THAT(text.str(), HasSubstr("e = 2 mm, sphere centre (2, 0, 0) mm"));
  EXPECT_THAT(json, HasSubstr("\"form_degree_max\": 2"));
  EXPECT_THAT(json, HasSubstr("\"separable\": true"));
}

}  // namespace
}  // namespace sph
