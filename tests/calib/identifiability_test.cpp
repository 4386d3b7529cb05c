// What a design separates, from its null space (sph/select/identifiability.hpp), on designs whose
// answer is known from their symmetry.
#include "sph/select/identifiability.hpp"
#include "sph/select/orientation_plan.hpp"

#include <algorithm>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/core/error.hpp"
#include "sph/simulation/simulate.hpp"

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

// The paper's machine and pattern with the sphere at `centers_mm` (one setup each; a radius in
// `radii_mm` for a setup that measures another sphere), read without noise, the model of `effects`
// on it and the factor of the pair (a, b), linearised at the truth.
struct EffectDesign {
  std::vector<Eigen::Vector3d> centers_mm;
  std::map<int, double> radii_mm;
  double phi_wobble_pivot_mm = 0.0;
};

EffectSeparability JudgeEffects(const EffectDesign& d, const std::vector<Effect>& effects, int harmonics = 4) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = d.centers_mm;
  spec.sphere_radii_mm = d.radii_mm;
  const PointsData points = SimulateExact(spec);
  CalibrationOptions options = PaperOptions();
  options.sphere_radii_mm = d.radii_mm;
  EffectModel model;
  model.reference = EffectReferenceOf(points.samples);
  model.phi_wobble_pivot_mm = d.phi_wobble_pivot_mm;
  for (const Effect e : effects) model.terms.push_back(DefaultTerm(e, harmonics));
  EffectFitStart at;
  at.geometry = spec.truth;
  at.centers_mm = spec.centers_mm;
  return IdentifyEffectPairs(points, options, model, at, {});
}

double Factor(const EffectSeparability& s, Effect a, Effect b) {
  for (const EffectPairInflation& p : s.pairs) {
    if ((p.a == a && p.b == b) || (p.a == b && p.b == a)) return p.factor;
  }
  ADD_FAILURE() << "no pair " << InfoOf(a).id << ", " << InfoOf(b).id;
  return 0.0;
}

const Eigen::Vector3d kAt2mm(2, 0, 0);

// A tilt of the Theta spindle about machine x and y through the axes' common point moves a sphere
// centred e from the axis, at that height, along the axis by e times the tilt: at one eccentricity
// a function of theta along z, as an axial error motion is. Its size grows with e, the axial
// motion's does not, so a second eccentricity tells them apart.
TEST(IdentifyEffectPairs, ASecondEccentricityTellsASpindleTiltFromAnAxialMotion) {
  const std::vector<Effect> effects{Effect::kThetaTiltMotion, Effect::kThetaAxialMotion};
  const EffectSeparability one = JudgeEffects({{kAt2mm}, {}, 0.0}, effects);
  EXPECT_TRUE(one.undetermined.empty());
  EXPECT_GT(Factor(one, effects[0], effects[1]), 1e6);
  const EffectSeparability two = JudgeEffects({{kAt2mm, Eigen::Vector3d(6, 0, 0)}, {}, 0.0}, effects);
  EXPECT_LE(Factor(two, effects[0], effects[1]), kSeparatedPairInflation);
}

// A tilt of the Phi axis about the probe's beam, pivoting at the bearing L along the axis, moves
// every point of the beam by L times the tilt across it, and turns the beam about itself, which
// moves nothing: a radial motion of the Phi axis across the beam does the same. No placement of any
// sphere tells them apart (only the tilt across the beam also turns it).
TEST(IdentifyEffectPairs, AWobbleAboutTheBeamIsARadialMotionOfThePhiAxisAnywhere) {
  const std::vector<Effect> effects{Effect::kPhiWobble, Effect::kPhiRadialMotion};
  const std::vector<EffectDesign> designs{{{kAt2mm}, {}, 80.0},
                                          {{kAt2mm, Eigen::Vector3d(6, 0, 0)}, {}, 80.0},
                                          {{kAt2mm, Eigen::Vector3d(2, 0, 15)}, {}, 80.0},
                                          {{kAt2mm, kAt2mm}, {{1, 10.0}}, 80.0}};
  for (std::size_t k = 0; k < designs.size(); ++k) {
    EXPECT_GT(Factor(JudgeEffects(designs[k], effects), effects[0], effects[1]), 1e6) << "design " << k;
  }
}

// With the sphere centred on the Theta axis a positioning error of Theta turns it about its own
// centre: nothing the probe reads changes, and the design does not determine the encoder error at
// all. Its pairs are not judged.
TEST(IdentifyEffectPairs, AnEncoderErrorOfTheAxisThroughTheSpheresCentreIsNotDetermined) {
  const EffectSeparability s =
      JudgeEffects({{Eigen::Vector3d::Zero()}, {}, 0.0}, {Effect::kThetaEncoder, Effect::kProbeDrift});
  EXPECT_EQ(s.undetermined, std::vector<Effect>{Effect::kThetaEncoder});
  EXPECT_TRUE(s.pairs.empty());
}

// On a grid of 24 theta steps (15 deg) sin(12 theta) is zero at every reading: that component of
// a Theta encoder error of orders 1..12 is not seen, and only it is left out; the others stay, and
// the effect is judged beside a drift.
TEST(IdentifyEffectPairs, LeavesOutOnlyTheComponentThePatternDoesNotSee) {
  const EffectSeparability s =
      JudgeEffects({{kAt2mm}, {}, 0.0}, {Effect::kThetaEncoder, Effect::kProbeDrift}, kMaxEffectHarmonic);
  EXPECT_TRUE(s.undetermined.empty());
  EXPECT_LE(Factor(s, Effect::kThetaEncoder, Effect::kProbeDrift), kSeparatedPairInflation);
}

// The probe's gain and its incidence error are both, at first order, a quadratic of the reading
// on one sphere (sin^2 psi = (e^2 - (rho - R0)^2) / R0^2); the gain's part goes as 1/R, the
// incidence's as 1/R^2, so a sphere of half the radius in the same place tells them apart. An
// encoder error of Theta and a drift of the probe are told apart by one placement.
TEST(IdentifyEffectPairs, ASecondSphereTellsAProbeGainFromAnIncidenceError) {
  const std::vector<Effect> effects{Effect::kProbeGain, Effect::kProbeIncidence, Effect::kThetaEncoder,
                                    Effect::kProbeDrift};
  const EffectSeparability one = JudgeEffects({{kAt2mm}, {}, 0.0}, effects);
  EXPECT_GT(Factor(one, effects[0], effects[1]), 1e3);
  EXPECT_LE(Factor(one, effects[2], effects[3]), kSeparatedPairInflation);
  const EffectSeparability two = JudgeEffects({{kAt2mm, kAt2mm}, {{1, 10.0}}, 0.0}, effects);
  EXPECT_LE(Factor(two, effects[0], effects[1]), kSeparatedPairInflation);
}

// The plan names, for each pair of effects its orientations leave confounded, the placement that
// separates it, and says so when none of those it tries does.
TEST(PlanOrientations, NamesThePlacementThatTellsTwoEffectsApart) {
  SimulationSpec design;
  OrientationPlanOptions options;
  options.effects = {Effect::kThetaTiltMotion, Effect::kThetaAxialMotion, Effect::kPhiWobble, Effect::kPhiRadialMotion};
  options.phi_wobble_pivot_mm = 80.0;
  options.form_degree_max = 4;
  const OrientationPlan plan = PlanOrientations(design, options);
  ASSERT_TRUE(plan.Separable());
  ASSERT_EQ(plan.confounded_effects.size(), 2u);
  for (const EffectPairAdvice& a : plan.confounded_effects) {
    EXPECT_GT(a.pair.factor, kSeparatedPairInflation);
    if (a.pair.a == Effect::kThetaTiltMotion) {
      EXPECT_EQ(a.pair.b, Effect::kThetaAxialMotion);
      EXPECT_FALSE(a.placement.empty());
      EXPECT_LE(a.factor_with, kSeparatedPairInflation);
    } else {
      EXPECT_EQ(a.pair.a, Effect::kPhiWobble);
      EXPECT_EQ(a.pair.b, Effect::kPhiRadialMotion);
      EXPECT_TRUE(a.placement.empty());
      EXPECT_GT(a.factor_with, kSeparatedPairInflation);
    }
  }
  EXPECT_NE(plan.placements_tried.find("three times the eccentricity"), std::string::npos);
}

}  // namespace
}  // namespace sph
