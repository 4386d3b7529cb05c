// Progress on stderr: into a log (not a terminal), a run that takes long enough leaves a line per
// stage and at most one every ten seconds within a stage; a short one leaves nothing.
#include "progress.hpp"

#include <chrono>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace sph::apps {
namespace {

int Lines(const std::string& s) {
  int n = 0;
  for (const char c : s) n += c == '\n' ? 1 : 0;
  return n;
}

TEST(Progress, IntoALogALinePerStageOnceTheRunIsLong) {
  std::ostringstream err;
  {
    Progress progress("sph_calibrate", err, ProgressMode::kAuto, std::chrono::milliseconds(0));
    progress.Stage("reading points.txt");
    for (long done = 1; done <= 200; ++done) progress.Update("tracing the residual, round 1: candidates", done, 200);
    progress.Stage("writing");
  }
  EXPECT_EQ(err.str(),
            "sph_calibrate: reading points.txt\n"
            "sph_calibrate: tracing the residual, round 1: candidates 0% (1/200)\n"
            "sph_calibrate: writing\n");
  EXPECT_EQ(Lines(err.str()), 3);
}

TEST(Progress, IntoALogNothingFromAShortRun) {
  std::ostringstream err;
  {
    Progress progress("sph_montecarlo", err, ProgressMode::kAuto);
    for (long done = 1; done <= 100; ++done) progress.Update("calibrating", done, 100);
  }
  EXPECT_EQ(err.str(), "");
}

TEST(Progress, AlwaysALinePerUpdateIntoALog) {
  std::ostringstream err;
  {
    Progress progress("sph_montecarlo", err, ProgressMode::kAlways);
    progress.Update("calibrating", 100, 100);
  }
  EXPECT_EQ(err.str(), "sph_montecarlo: calibrating 100% (100/100)\n");
}

}  // namespace
}  // namespace sph::apps
