// What a design separates, from its null space (sph/calib/identifiability.hpp), on designs whose
// answer is known from their symmetry.
#include "sph/calib/identifiability.hpp"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/core/simulate.hpp"

namespace sph {
namespace {

using sph::testing::PaperOptions;

// The paper's machine and pattern, the sphere at 2 mm in three setups with the mount rotations
// given (rotation vectors, degrees; one per setup).
PointsData Design(const std::vector<Eigen::Vector3d>& rotations_deg) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(-2, 0, 0)};
  for (std::size_t k = 0; k < rotations_deg.size(); ++k) spec.mount_rotations_deg[static_cast<int>(k)] = rotations_deg[k];
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
  one.samples.erase(std::remove_if(one.samples.begin(), one.samples.end(), [](const Sample& s) { return s.setup != 0; }),
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
  one.samples.erase(std::remove_if(one.samples.begin(), one.samples.end(), [](const Sample& s) { return s.setup != 0; }),
                    one.samples.end());
  one.header.mount_rotations.clear();
  const std::vector<FormTerm> terms = FormTermsOfDegrees(2, 3);
  const FormIdentifiability all = IdentifyForm(points, PaperOptions(), PhiEffects(points), At(points), terms);
  const FormIdentifiability single = IdentifyForm(one, PaperOptions(), PhiEffects(one), At(one), terms);
  for (const FormTerm& t : single.confounded) EXPECT_TRUE(Contains(all.confounded, t)) << t.l << "," << t.m;
  EXPECT_GE(all.confounded.size(), single.confounded.size());
}

}  // namespace
}  // namespace sph
