// What a design separates, from its null space (sph/calib/identifiability.hpp), on designs whose
// answer is known from their symmetry.
#include "sph/calib/identifiability.hpp"
#include "sph/calib/orientation_plan.hpp"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/core/error.hpp"
#include "sph/core/simulate.hpp"

namespace sph {
namespace {

using sph::testing::PaperOptions;

// The paper's machine and pattern, the sphere at 2 mm in three setups with the mount rotations
// given (rotation vectors, degrees; one per setup).
PointsData Design(const std::vector<Eigen::Vector3d>& rotations_deg) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(-2, 0, 0)};
  for (std::size_t k = 0; k < rotations_deg.size(); ++k)
    spec.mount_rotations_deg[static_cast<int>(k)] = rotations_deg[k];
  spec.noise_r_um = 0.0;
  return Simulate(spec);
}

EffectFitStart At(const PointsData& points) { return EffectFitStart::From(Calibrate(points, PaperOptions())); }

bool Contains(const std::vector<FormTerm>& terms, FormTerm t) {
  return std::find(terms.begin(), terms.end(), t) != terms.end();
}

EffectModel PhiEffects(const PointsData& points) {
  EffectModel machine;
  machine.reference = EffectReferenceOf(points.samples);
  machine.terms = {DefaultTerm(Effect::kPhiEncoder), DefaultTerm(Effect::kPhiWobble)};
  return machine;
}

// Turning the sphere with its mount on the Theta table about the Theta axis, centre and all, is a
// shift of theta: to a machine whose errors do not depend on theta (the seven errors, the Phi
// axis' errors) the turned setups read what the first reads at other theta. So what such a machine
// can mimic of the form in one placement stays confounded however often the sphere is turned so;
// here the m = +-1 terms, with the Phi axis' wobble and the seven errors.
TEST(IdentifyForm, TurnsOnTheThetaTableAreOnePlacementToAThetaFreeMachine) {
  const PointsData turned = Design({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 90), Eigen::Vector3d(0, 0, 180)});
  PointsData one = turned;
  one.samples.erase(
      std::remove_if(one.samples.begin(), one.samples.end(), [](const Sample& s) { return s.setup != 0; }),
      one.samples.end());
  one.header.mount_rotations.clear();
  const std::vector<FormTerm> terms = FormTermsOfDegrees(2, 4);
  const FormIdentifiability a = IdentifyForm(turned, PaperOptions(), PhiEffects(turned), At(turned), terms);
  const FormIdentifiability b = IdentifyForm(one, PaperOptions(), PhiEffects(one), At(one), terms);
  ASSERT_FALSE(b.confounded.empty());
  EXPECT_EQ(a.confounded, b.confounded);
  ASSERT_FALSE(a.combinations.empty());
  EXPECT_NE(a.combinations.front().words.find("phi_wobble"), std::string::npos) << a.combinations.front().words;
}

// A tilt of 90 deg about x on top of the turns: every term of degrees 2..4 is separable.
TEST(IdentifyForm, ATiltSeparatesEveryTerm) {
  const PointsData points = Design({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 90), Eigen::Vector3d(90, 0, 0)});
  const FormIdentifiability id =
      IdentifyForm(points, PaperOptions(), PhiEffects(points), At(points), FormTermsOfDegrees(2, 4));
  EXPECT_TRUE(id.confounded.empty());
  EXPECT_TRUE(id.combinations.empty());
  EXPECT_EQ(id.separable.size(), FormTermsOfDegrees(2, 4).size());
}

// Every setup remounted at an unknown orientation: each has a form of its own, tied to nothing, so
// whatever the machine mimics in one placement it mimics in each, and more is confounded than with
// one placement of known orientation.
TEST(IdentifyForm, UnknownOrientationsTieNothingToTheSphere) {
  PointsData points = Design({});
  for (const int id : points.SetupIds()) points.header.mount_rotations[id] = MountRotation::Unknown();
  PointsData one = points;
  one.samples.erase(
      std::remove_if(one.samples.begin(), one.samples.end(), [](const Sample& s) { return s.setup != 0; }),
      one.samples.end());
  one.header.mount_rotations.clear();
  const std::vector<FormTerm> terms = FormTermsOfDegrees(2, 3);
  const FormIdentifiability all = IdentifyForm(points, PaperOptions(), PhiEffects(points), At(points), terms);
  const FormIdentifiability single = IdentifyForm(one, PaperOptions(), PhiEffects(one), At(one), terms);
  for (const FormTerm& t : single.confounded) EXPECT_TRUE(Contains(all.confounded, t)) << t.l << "," << t.m;
  EXPECT_GE(all.confounded.size(), single.confounded.size());
}

// The plan for the Phi axis' effects and degrees 2..4 from the default candidates: one placement
// leaves terms confounded; each orientation the plan adds lowers their count, and the last leaves
// none. Judged again on the design read by Simulate() at the plan's orientations and linearised
// at its calibration rather than at the truth, the plan holds.
TEST(PlanOrientations, SeparatesThePhiAxisEffectsFromTheForm) {
  SimulationSpec design;
  OrientationPlanOptions options;
  options.effects = {Effect::kPhiEncoder, Effect::kPhiWobble};
  options.form_degree_max = 4;
  const OrientationPlan plan = PlanOrientations(design, options);
  ASSERT_GE(plan.steps.size(), 2u);
  EXPECT_FALSE(plan.steps.front().identifiability.confounded.empty());
  for (std::size_t k = 1; k < plan.steps.size(); ++k) {
    EXPECT_LT(plan.steps[k].identifiability.confounded.size(), plan.steps[k - 1].identifiability.confounded.size());
  }
  ASSERT_TRUE(plan.Separable());
  EXPECT_LE(plan.steps.size(), 3u);

  SimulationSpec check;
  check.noise_r_um = 0.0;
  check.centers_mm.assign(plan.steps.size(), design.centers_mm.front());
  for (std::size_t k = 0; k < plan.steps.size(); ++k)
    check.mount_rotations_deg[static_cast<int>(k)] = plan.steps[k].rotation_deg;
  const PointsData points = Simulate(check);
  EffectModel machine = PhiEffects(points);
  const FormIdentifiability id = IdentifyForm(points, PaperOptions(), machine, At(points), FormTermsOfDegrees(2, 4));
  EXPECT_TRUE(id.confounded.empty());
}

// With the sphere centred at the axes' common point the probed direction's polar angle is phi, so
// a zonal term S(l,0) of the form is a function of phi alone, as the radial error motion of the
// Phi axis is, and a turn of the sphere about z leaves S(l,0) as it was: candidates that only turn
// the sphere about z cannot separate them, and the plan says so and stops. A tilt separates them.
TEST(PlanOrientations, SaysWhenTheCandidatesCannotSeparate) {
  SimulationSpec design;
  design.centers_mm = {Eigen::Vector3d::Zero()};
  OrientationPlanOptions options;
  options.effects = {Effect::kPhiRadialMotion};
  options.form_degree_max = 4;
  options.candidates_deg = {Eigen::Vector3d(0, 0, 90), Eigen::Vector3d(0, 0, 180)};
  const OrientationPlan plan = PlanOrientations(design, options);
  EXPECT_FALSE(plan.Separable());
  EXPECT_EQ(plan.steps.size(), 1u);
  const std::vector<FormTerm> zonal{{2, 0}, {3, 0}, {4, 0}};
  EXPECT_EQ(plan.steps.back().identifiability.confounded, zonal);
  options.candidates_deg.push_back(Eigen::Vector3d(90, 0, 0));
  const OrientationPlan tilted = PlanOrientations(design, options);
  ASSERT_TRUE(tilted.Separable());
  EXPECT_EQ(tilted.steps.back().rotation_deg, Eigen::Vector3d(90, 0, 0));
}

TEST(PlanOrientations, RefusesAnImpossibleRequest) {
  OrientationPlanOptions options;
  options.form_degree_max = 1;
  EXPECT_THROW(PlanOrientations(SimulationSpec{}, options), Error);
  options.form_degree_max = 4;
  options.max_orientations = 0;
  EXPECT_THROW(PlanOrientations(SimulationSpec{}, options), Error);
}

}  // namespace
}  // namespace sph
