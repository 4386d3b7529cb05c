// The sphere's form fitted jointly with the seven errors, the centres and the machine effects.
#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/form_report.hpp"
#include "sph/select/trace.hpp"
#include "sph/select/trace_report.hpp"

namespace sph {
namespace {

using sph::testing::PaperOptions;

// Three setups: the reference orientation at (2, 0, 0) mm, a turn of 90 deg about Theta at
// (0, 2, 0) mm, and the sphere remounted at an orientation the file calls unknown (a tilt).
PointsData ThreeSetups(double noise_um, const std::vector<FormComponent>& form, std::uint64_t seed) {
  SimulationSpec spec;
  spec.pattern = GridPattern(24, 12);
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(-2, 0, 0.5)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(0, 0, 90);
  spec.mount_rotations_deg[2] = Eigen::Vector3d(90, 0, 0);
  spec.mount_unknown.insert(2);
  spec.noise_r_um = noise_um;
  spec.seed = seed;
  spec.effects.form = form;
  return Simulate(spec);
}

// Hand-worked: with no errors and the centre at the origin, the probe at phi = 0 looks along the
// Theta axis and meets the point (0, 0, d - r). A form c S_20 is c at the body's pole and -c/2 on
// its equator: e = |p| - R0 - F.
TEST(FormFit, ResidualHandWorked) {
  PointsData points;
  points.source = "hand";
  const double c_mm = 0.01, d = 25.0, r0 = 20.0;
  points.samples.push_back({0.0, 0.0, d - (r0 + c_mm), 0.0, 0});
  points.samples.push_back({0.0, 0.0, d - (r0 + c_mm), 1.0, 1});
  points.header.mount_rotations[1] = MountRotation::Known(Eigen::Vector3d(90, 0, 0));
  EffectFit fit;
  fit.model.form = FormModelOf(points, {{2, 0}});
  ASSERT_EQ(fit.model.form.NumGroups(), 1);  // both orientations known: one set
  fit.form_values = {{c_mm}};
  fit.calibration.setup_ids = {0, 1};
  fit.calibration.centers_mm = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  const std::vector<double> e = EffectResiduals(points, PaperOptions(), fit);
  // To the rounding of lengths of 20 mm (4e-15 mm).
  EXPECT_NEAR(e[0], 0.0, 1e-14);  // the body's pole: on the surface
  // Tilted 90 deg about x, the Theta frame's z axis is the body direction R^T z = (0, 1, 0): the
  // equator, where the surface is at R0 - c/2.
  EXPECT_NEAR(e[1], c_mm + 0.5 * c_mm, 1e-14);
}

// Setups of unknown orientation get their own coefficient set; known ones share one.
TEST(FormFit, GroupsOfTheSetups) {
  const PointsData points = ThreeSetups(0.0, {}, 1);
  const FormModel form = FormModelOf(points, FormTermsOfDegrees(2, 3));
  ASSERT_EQ(form.NumGroups(), 2);
  EXPECT_EQ(form.SetupOf(0).group, 0);
  EXPECT_EQ(form.SetupOf(1).group, 0);
  EXPECT_EQ(form.SetupOf(2).group, 1);
  EXPECT_NEAR((form.SetupOf(1).rotation * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-15);
  EXPECT_EQ(form.NumParams(), 2 * 12);
  EXPECT_EQ(form.ParamName(1, 0), "sphere_form@2.S(2,-2)");
}

// Another sphere has a set of its own, shared by the setups that measured it (the same radius),
// each at its mount rotation on that sphere's body; a sphere of a third radius has its own again.
TEST(FormFit, AnotherSphereHasASetSharedByItsSetups) {
  PointsData points;
  points.has_setup = true;
  for (int id = 0; id < 5; ++id) points.samples.push_back({0.0, 7.5, 5.0, 0.0, id});
  points.header.sphere_radii_mm = {{1, 10.0}, {3, 10.0}, {4, 12.0}};
  points.header.mount_rotations[3] = MountRotation::Known(Eigen::Vector3d(0, 0, 90));
  const FormModel form = FormModelOf(points, FormTermsOfDegrees(2, 2));
  ASSERT_EQ(form.NumGroups(), 3);
  EXPECT_EQ(form.SetupOf(0).group, 0);
  EXPECT_EQ(form.SetupOf(2).group, 0);
  EXPECT_EQ(form.SetupOf(1).group, 1);
  EXPECT_EQ(form.SetupOf(3).group, 1);
  EXPECT_EQ(form.SetupOf(4).group, 2);
  EXPECT_NEAR((form.SetupOf(3).rotation * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-15);
  EXPECT_EQ(form.ParamName(1, 0), "sphere_form@1,3.S(2,-2)");
  EXPECT_EQ(form.ParamName(2, 0), "sphere_form@4.S(2,-2)");
}

// The hand-derived Jacobian with a form (the reverse sweep less the sweep along dF/dp, see
// src/calib/fit_problem.hpp) equals central differences of EffectResiduals(), which evaluates the
// point by EffectScmsPoint() and the form by FormValue(): another code path. The form is large
// (micrometres) so that its tangential part, about l F / R0 of the columns, is far above the
// tolerance.
// with_incidence: probe_incidence beside the form. Its chain through the incidence angle adds to
// de/dO, and the form must still be taken at the unit normal, not at -de/dO.
void CheckFormJacobian(bool with_incidence) {
  SimulationSpec spec;
  spec.pattern = GridPattern(12, 6);
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, -1.5, 0.5), Eigen::Vector3d(-1, 0, 0)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(10, 20, 90);
  spec.mount_unknown.insert(2);
  const PointsData points = Simulate(spec);
  EffectModel model;
  model.terms.push_back(DefaultTerm(Effect::kThetaEncoder, 2));
  model.terms.push_back(DefaultTerm(Effect::kPhiWobble, 1));
  model.terms.push_back(DefaultTerm(Effect::kProbeGain));
  if (with_incidence) model.terms.push_back(DefaultTerm(Effect::kProbeIncidence));
  model.reference = EffectReferenceOf(points.samples);
  model.form = FormModelOf(points, FormTermsOfDegrees(2, 4));
  ASSERT_EQ(model.form.NumGroups(), 2);
  CalibrationOptions o = PaperOptions();
  o.max_iterations = 1;
  EffectFit fit = FitEffects(points, o, model, EffectFitStart::From(Calibrate(points, PaperOptions())));
  // Parameters away from zero, the form of a few micrometres; an incidence error of micrometres, so
  // that its chain is far above the tolerance.
  for (std::size_t t = 0; t < fit.values.size(); ++t) {
    const double size = fit.model.terms[t].effect == Effect::kProbeIncidence ? 3e-3 : 2e-5;
    for (std::size_t i = 0; i < fit.values[t].size(); ++i) {
      fit.values[t][i] = size * (1.0 + 0.3 * static_cast<double>(i));
    }
  }
  for (std::size_t g = 0; g < fit.form_values.size(); ++g) {
    for (std::size_t k = 0; k < fit.form_values[g].size(); ++k) {
      fit.form_values[g][k] = 3e-3 * std::cos(1.7 * static_cast<double>(k) + static_cast<double>(g));
    }
  }
  const Eigen::MatrixXd jacobian = JacobianAt(points, o, fit);
  ASSERT_EQ(jacobian.cols(), fit.n_params);
  EffectFit probe = fit;
  int col = 0;
  double largest_tangential = 0.0;
  auto difference = [&](double& value, double h) {
    const double keep = value;
    value = keep + h;
    const std::vector<double> plus = EffectResiduals(points, o, probe);
    value = keep - h;
    const std::vector<double> minus = EffectResiduals(points, o, probe);
    value = keep;
    double worst = 0.0, scale = 0.0;
    for (std::size_t i = 0; i < plus.size(); ++i) {
      const double numeric = (plus[i] - minus[i]) / (2 * h);
      worst = std::max(worst, std::abs(numeric - jacobian(static_cast<Eigen::Index>(i), col)));
      scale = std::max(scale, std::abs(numeric));
    }
    EXPECT_LE(worst, 1e-7 * std::max(scale, 1.0))
        << "column " << col << " (" << fit.calibration.analysis.parameters[static_cast<std::size_t>(col)].name << ")";
    ++col;
  };
  for (double& g : probe.calibration.geometry) difference(g, 1e-6);
  for (auto& c : probe.calibration.centers_mm) {
    for (int j = 0; j < 3; ++j) difference(c(j), 1e-6);
  }
  for (auto& block : probe.values) {
    for (double& v : block) difference(v, 1e-6);
  }
  for (auto& block : probe.form_values) {
    for (double& v : block) difference(v, 1e-6);
  }
  EXPECT_EQ(col, fit.n_params);
  // The centre columns are -n + t: without t they would differ from -n by l F / R0, here about
  // 1e-3 (checked so that the test above is known to see the tangential part).
  EffectFit no_form = fit;
  for (auto& block : no_form.form_values) std::fill(block.begin(), block.end(), 0.0);
  const Eigen::MatrixXd plain = JacobianAt(points, o, no_form);
  largest_tangential =
      (jacobian.leftCols(kNumScmsParams + 9) - plain.leftCols(kNumScmsParams + 9)).cwiseAbs().maxCoeff();
  EXPECT_GT(largest_tangential, 1e-4);
}

TEST(FormFit, JacobianMatchesCentralDifferences) { CheckFormJacobian(false); }

TEST(FormFit, JacobianWithProbeIncidenceMatchesCentralDifferences) { CheckFormJacobian(true); }

// Ray-traced by the simulator (code of its own): the sphere in three orientations (two known, one
// unknown), a form of 0.05 um RMS of degrees 2 to 4 and a Theta encoder error of 5" at 3 per turn,
// sigma_r 0.03 um. The joint fit of the seven errors, the centres, the encoder term and the form
// recovers the encoder error within 4 std and the form's RMS within 20 %.
TEST(FormFit, RecoversFormAndEffectFromRayTracedData) {
  std::vector<FormComponent> form = {{2, 0, 0.06},   {2, 2, -0.05}, {3, 1, 0.05},  {3, -3, 0.04},
                                     {4, 0, -0.045}, {4, 2, 0.03},  {4, -4, 0.035}};
  double sum = 0.0;
  for (const FormComponent& f : form) sum += f.amplitude_um * f.amplitude_um / (2.0 * f.l + 1.0);
  const double scale = 0.05 / std::sqrt(sum);
  for (FormComponent& f : form) f.amplitude_um *= scale;
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(0, 0, 90);
  spec.mount_rotations_deg[2] = Eigen::Vector3d(90, 0, 0);
  spec.noise_r_um = 0.03;
  spec.seed = 21;
  spec.effects.form = form;
  EffectTerm encoder;
  encoder.effect = Effect::kThetaEncoder;
  encoder.components = {{3, 0, false}, {3, 0, true}};
  spec.effects.model.terms = {encoder};
  const double c3_rad = 5.0 * kRadPerArcsec;
  spec.effects.values = {{c3_rad, 0.0}};
  const PointsData points = Simulate(spec);

  EffectModel model;
  model.terms = {encoder};
  model.reference = EffectReferenceOf(points.samples);
  model.form = FormModelOf(points, FormTermsOfDegrees(2, 4));
  const EffectFit fit =
      FitEffects(points, PaperOptions(), model, EffectFitStart::From(Calibrate(points, PaperOptions())));
  ASSERT_TRUE(fit.calibration.converged) << fit.calibration.solver_message;
  const ObservabilityReport& rep = fit.calibration.analysis;
  const int enc = fit.TermOffset(0);
  EXPECT_NEAR(fit.values[0][0], c3_rad, 4.0 * rep.std(enc)) << "std " << rep.std(enc) / kRadPerArcsec << " arcsec";
  EXPECT_NEAR(fit.values[0][1], 0.0, 4.0 * rep.std(enc + 1));
  EXPECT_LT(rep.std(enc), 0.5 * kRadPerArcsec);  // determined well enough for the 4-std test to mean something
  const double rms_um = FormRms(model.form.terms, fit.form_values[0]) * kUmPerMm;
  EXPECT_NEAR(rms_um, 0.05, 0.2 * 0.05);
  // The residual is the noise: nothing of the form is left in it.
  EXPECT_LT(fit.calibration.rms_um, 0.033);
  // Each coefficient within 4 std of the simulated amplitude (the others zero).
  for (std::size_t k = 0; k < model.form.terms.size(); ++k) {
    double truth_um = 0.0;
    for (const FormComponent& f : form) {
      if (f.l == model.form.terms[k].l && f.m == model.form.terms[k].m) truth_um = f.amplitude_um;
    }
    const int col = fit.FormOffset(0) + static_cast<int>(k);
    EXPECT_NEAR(fit.form_values[0][k] * kUmPerMm, truth_um, 4.0 * rep.std(col) * kUmPerMm)
        << model.form.ParamName(0, k);
  }
}

// A form of 0.05 um RMS of degrees 2 to 4 on the sphere's body frame (amplitudes scaled to it).
std::vector<FormComponent> FormOfDegrees2To4() {
  std::vector<FormComponent> form = {{2, 0, 0.06},   {2, 2, -0.05}, {3, 1, 0.05},  {3, -3, 0.04},
                                     {4, 0, -0.045}, {4, 2, 0.03},  {4, -4, 0.035}};
  double sum = 0.0;
  for (const FormComponent& f : form) sum += f.amplitude_um * f.amplitude_um / (2.0 * f.l + 1.0);
  for (FormComponent& f : form) f.amplitude_um *= 0.05 / std::sqrt(sum);
  return form;
}

TraceOptions FewCandidates() {
  TraceOptions t;
  t.candidates = {Effect::kThetaEncoder, Effect::kPhiEncoder, Effect::kProbeGain, Effect::kProbeDrift};
  t.form_degree_max = 6;
  t.threads = 2;
  return t;
}

// A form of 0.050 um rms of degrees 2..8 (the studies' form28).
std::vector<FormComponent> Form28() {
  return {{2, 0, 0.062},  {2, 2, -0.049}, {3, 1, 0.049},  {3, -3, 0.037}, {4, 0, -0.043}, {4, 2, 0.031}, {5, -2, 0.037},
          {5, 4, -0.025}, {6, 1, 0.031},  {6, -5, 0.025}, {7, 3, -0.025}, {8, 0, 0.025},  {8, -6, 0.019}};
}

// The sphere at (2, 0, 0) mm, turned by 90 deg about z at (0, 2, 0) mm and tilted by 90 deg about x
// at (2, 0, 0) mm, each setup in another scan order: the eccentricity points along the body's x
// axis in every setup.
SimulationSpec TurnedAndTilted() {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(0, 0, 90);
  spec.mount_rotations_deg[2] = Eigen::Vector3d(90, 0, 0);
  spec.scan_orders[1] = ScanOrder::kSerpentine;
  spec.scan_orders[2] = ScanOrder::kColumns;
  return spec;
}

// Ray-traced: the sphere turned about Theta and tilted, each setup in another scan order, a form
// and a probe drift. The trace fits the form as part of the model (it turns with the sphere) and
// adds the drift and nothing else; the form's RMS within 20 %, the drift within 4 std.
TEST(TraceWithForm, SeparatesTheFormFromADriftWhenTheSphereIsTurned) {
  SimulationSpec spec = TurnedAndTilted();
  spec.noise_r_um = 0.03;
  spec.seed = 31;
  spec.effects.form = FormOfDegrees2To4();
  spec.effects.model.terms = {DefaultTerm(Effect::kProbeDrift, 1, 1)};
  spec.effects.values = {{0.4 * kMmPerUm}};
  const PointsData points = Simulate(spec);
  const CalibrationResult base = Calibrate(points, PaperOptions());
  const TraceResult r = TraceResidual(points, PaperOptions(), base, FewCandidates());
  EXPECT_TRUE(r.form.separable) << r.form.design;
  ASSERT_EQ(r.added, std::vector<Effect>{Effect::kProbeDrift});
  const EffectFit& fit = r.after.fit;
  ASSERT_FALSE(fit.model.form.Empty());
  EXPECT_GE(r.form.degree_max, 4);
  const std::vector<SphereFormResult> forms = SphereFormOf(fit);
  ASSERT_EQ(forms.size(), 1u);
  EXPECT_NEAR(forms[0].rms_um, 0.05, 0.2 * 0.05);
  EXPECT_NEAR(fit.values[0][0] * kUmPerMm, 0.4, 4.0 * fit.calibration.analysis.std(fit.TermOffset(0)) * kUmPerMm);
  EXPECT_LT(r.after.cv_rms_um, 1.1 * 0.03);
}

// One placement, the same form and no machine effect: nothing is added.
TEST(TraceWithForm, OnePlacementAddsNoEffectForAForm) {
  SimulationSpec spec;
  spec.noise_r_um = 0.03;
  spec.seed = 32;
  spec.effects.form = FormOfDegrees2To4();
  const PointsData points = Simulate(spec);
  const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), FewCandidates());
  EXPECT_FALSE(r.form.separable);
  EXPECT_TRUE(r.added.empty()) << InfoOf(r.added.front()).id;
}

// One placement, a form of degrees 2..8 and a Phi encoder error of 10 arcsec at one per turn. A
// power of the probe reading is then a form of low degree, and what probe_nonlinearity showed
// beyond the degrees 2..5 of the pattern it competes with was the form's degrees 6..8 (it was added
// in every one of 5 seeds before the probe terms were held to that): no probe term is added, and
// the two explanations, a pattern on the sphere or a probe term, are reported with their sizes and
// the measurement that tells them apart.
TEST(TraceWithForm, OnePlacementAddsNoProbeTermForTheFormsHigherDegrees) {
  for (const std::uint64_t seed : {1, 2, 3}) {
    SimulationSpec spec;
    spec.noise_r_um = 0.03;
    spec.seed = seed;
    spec.effects.form = Form28();
    spec.effects.model.terms = {{Effect::kPhiEncoder, {{1, 0, false}}}};
    spec.effects.values = {{10 * kRadPerArcsec}};
    const PointsData points = Simulate(spec);
    const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), TraceOptions{});
    ASSERT_FALSE(r.form.separable);
    for (const Effect e : r.added) {
      EXPECT_NE(InfoOf(e).variable, std::string("r")) << "seed " << seed << ": " << InfoOf(e).id;
    }
    const auto two = std::find_if(r.ambiguous.begin(), r.ambiguous.end(), [](const Ambiguity& a) {
      return a.chosen == "sphere_form" && InfoOf(Effect::kProbeNonlinearity).id == a.other;
    });
    ASSERT_NE(two, r.ambiguous.end()) << "seed " << seed;
    EXPECT_GT(two->chosen_rms_um, 0.0);
    EXPECT_GT(two->other_rms_um, 0.0);
    EXPECT_NE(two->separate_by.find("eccentricity"), std::string::npos) << two->separate_by;
  }
}

// Turned and tilted (TurnedAndTilted()): the probe reading is then a function of the body's
// direction, and its polynomial is one more form turning with the sphere. A form of degrees 2..8
// and no machine effect; with this seed the trace's form of degrees 2..3 leaves enough of it that
// probe_nonlinearity's u3 qualifies beside it (extended delta BIC -18.7), but is not separable
// from the form of degrees 2..8 (its variance inflation there is about 10^7): nothing is added,
// and the two explanations are reported with the measurement that separates them.
TEST(TraceWithForm, AddsNoProbeTermThatAFormOfAHigherDegreeExplains) {
  SimulationSpec spec = TurnedAndTilted();
  spec.seed = 1050;
  spec.effects.form = Form28();
  const PointsData points = Simulate(spec);
  const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), TraceOptions{});
  ASSERT_TRUE(r.form.separable) << r.form.design;
  EXPECT_TRUE(r.added.empty()) << InfoOf(r.added.front()).id;
  const auto two = std::find_if(r.ambiguous.begin(), r.ambiguous.end(), [](const Ambiguity& a) {
    return a.chosen == "sphere_form" && a.other == "probe_nonlinearity" && a.form_turns_with_sphere;
  });
  ASSERT_NE(two, r.ambiguous.end());
  EXPECT_NE(two->separate_by.find("eccentricity elsewhere on its body"), std::string::npos) << two->separate_by;
  const auto nonlinearity = std::find_if(r.candidates.begin(), r.candidates.end(), [](const CandidateScore& c) {
    return !c.sphere_form && c.effect == Effect::kProbeNonlinearity && c.round == 1;
  });
  ASSERT_NE(nonlinearity, r.candidates.end());
  EXPECT_LE(nonlinearity->delta_bic, -TraceOptions{}.min_delta_bic);  // it qualified without the higher degrees
  EXPECT_FALSE(nonlinearity->added);
}

// A form of 0.0213 um rms fitted at degrees 2..6 (45 coefficients per set) with the sphere in one
// placement, a set of its own (the setup of unknown orientation, 288 readings, sigma 0.05 um): the
// coefficients' noise adds about 0.014 um in quadrature, so their RMS reads about 0.03 um. The
// reported RMS takes that share out and comes back within 2 of its standard uncertainties of the
// truth in every seed, and within 15 % on average over the seeds (the RMS as fitted: 40 % high).
TEST(SphereFormOf, TakesTheCoefficientsNoiseOutOfTheRms) {
  std::vector<FormComponent> form = FormOfDegrees2To4();
  const double truth_um = 0.0213;
  for (FormComponent& f : form) f.amplitude_um *= truth_um / 0.05;
  constexpr int kSeeds = 6;
  double corrected = 0.0, fitted = 0.0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    SimulationSpec spec = TurnedAndTilted();
    spec.centers_mm.emplace_back(2, 0, 0);
    spec.mount_rotations_deg[3] = Eigen::Vector3d(0, 90, 0);
    spec.mount_unknown.insert(3);
    spec.noise_r_um = 0.05;
    spec.seed = 700 + static_cast<std::uint64_t>(seed);
    spec.effects.form = form;
    const PointsData points = Simulate(spec);
    EffectModel model;
    model.reference = EffectReferenceOf(points.samples);
    model.form = FormModelOf(points, FormTermsOfDegrees(2, 6));
    const EffectFit fit =
        FitEffects(points, PaperOptions(), model, EffectFitStart::From(Calibrate(points, PaperOptions())));
    ASSERT_TRUE(fit.calibration.converged) << fit.calibration.solver_message;
    const std::vector<SphereFormResult> forms = SphereFormOf(fit);
    ASSERT_EQ(forms.size(), 2u);
    const SphereFormResult& own = forms[1];  // one placement: the setup of unknown orientation
    ASSERT_EQ(own.terms.size(), 45u);
    EXPECT_GT(own.rms_noise_um, 0.010);
    EXPECT_NEAR(own.rms_um,
                std::sqrt(std::max(0.0, own.rms_fitted_um * own.rms_fitted_um - own.rms_noise_um * own.rms_noise_um)),
                1e-12);
    EXPECT_NEAR(own.rms_um, truth_um, 2.0 * own.rms_std_um)
        << "seed " << seed << ": fitted " << own.rms_fitted_um << ", noise " << own.rms_noise_um;
    corrected += own.rms_um / kSeeds;
    fitted += own.rms_fitted_um / kSeeds;
  }
  EXPECT_NEAR(corrected, truth_um, 0.15 * truth_um);
  EXPECT_GT(fitted, 1.25 * truth_um);  // what the correction takes out
}

// The turned design with form28 (0.050 um rms of degrees 2..8, sigma 0.05 um): the extended BIC
// cuts the form at degree 4, whose RMS reads 16 % low, more than twice the noise's uncertainty
// alone (0.0024 um). The uncertainty includes what the degrees up to the limit searched could add
// (the simulated form has 0.020 um rms above degree 4), and covers the truth at k = 2.
TEST(SphereFormOf, TheRmsUncertaintyIncludesTheDegreeChosen) {
  SimulationSpec spec = TurnedAndTilted();
  spec.noise_r_um = 0.05;
  spec.seed = 2;
  spec.effects.form = Form28();
  const PointsData points = Simulate(spec);
  TraceOptions options = FewCandidates();
  options.form_degree_max = 8;
  const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), options);
  ASSERT_TRUE(r.form.separable) << r.form.design;
  ASSERT_GT(r.form.degree_max, 0);
  ASSERT_LT(r.form.degree_max, r.form.degree_limit);
  const std::vector<SphereFormResult> forms = SphereFormOf(r);
  ASSERT_EQ(forms.size(), 1u);
  const SphereFormResult& f = forms[0];
  EXPECT_EQ(f.higher_degree_limit, r.form.degree_limit);
  EXPECT_GT(f.higher_rms_max_um, 0.020);
  EXPECT_GT(std::abs(f.rms_um - 0.050), 2.0 * f.rms_noise_std_um);  // the case: the noise alone does not cover it
  EXPECT_NEAR(f.rms_um, 0.050, 2.0 * f.rms_std_um);
}

// The transfer test's mechanics: two positions of a sphere read without noise by the machine that
// the seven errors describe; each position predicted from the fit of the other, its centre
// refitted (from 10 um off), is read exactly (to the solver's tolerance). One setup: nothing to
// leave out.
TEST(LeaveOneSetupOut, PredictsNoiseFreeReadingsExactly) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, -1.5, 1)};
  spec.noise_r_um = 0.0;
  const PointsData points = Simulate(spec);
  EffectModel none;
  none.reference = EffectReferenceOf(points.samples);
  EffectFit fit = FitEffects(points, PaperOptions(), none, EffectFitStart::From(Calibrate(points, PaperOptions())));
  for (Eigen::Vector3d& c : fit.calibration.centers_mm) c += Eigen::Vector3d(0.01, -0.01, 0.01);
  EXPECT_LT(LeaveOneSetupOutRms(points, PaperOptions(), fit), 1e-4);
  SimulationSpec one;
  one.noise_r_um = 0.0;
  const PointsData single = Simulate(one);
  EXPECT_TRUE(std::isnan(LeaveOneSetupOutRms(
      single, PaperOptions(),
      FitEffects(single, PaperOptions(), none, EffectFitStart::From(Calibrate(single, PaperOptions()))))));
}

// Two setups at (2, 0, 0) mm, one of known orientation and the sphere remounted, turned by 90 deg
// about y and scanned in serpentine, in an orientation the file calls unknown; form28 and a Phi
// encoder error of 10 arcsec once per turn (sigma_r 0.05 um).
SimulationSpec KnownAndUnknown(std::uint64_t seed) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(0, 90, 0);
  spec.mount_unknown.insert(1);
  spec.scan_orders[1] = ScanOrder::kSerpentine;
  spec.effects.model.terms = {{Effect::kPhiEncoder, {{1, 0, false}}}};
  spec.effects.values = {{10 * kRadPerArcsec}};
  spec.effects.form = Form28();
  return spec;
}

// Whether the trace found the Phi encoder error, or added a Phi effect that it names as ambiguous
// with it.
bool FoundOrNamedThePhiEncoder(const TraceResult& r) {
  if (std::find(r.added.begin(), r.added.end(), Effect::kPhiEncoder) != r.added.end()) return true;
  return std::any_of(r.ambiguous.begin(), r.ambiguous.end(), [&](const Ambiguity& a) {
    Effect chosen{};
    return a.other == "phi_encoder" && EffectFromId(a.chosen, &chosen) &&
           std::find(r.added.begin(), r.added.end(), chosen) != r.added.end();
  });
}

// Whether the trace found the Phi encoder error, named it with a Phi effect added, or, nothing
// added, named a Phi effect (the encoder, or the radial motion that scores about as well) beside
// the pattern fixed on each setup's sphere: with a form of its own the unknown setup's pattern
// holds any function of its directions, the encoder error's among them, two explanations this
// design does not tell apart.
bool FoundOrNamedThePhiEncoderOrThePattern(const TraceResult& r) {
  return FoundOrNamedThePhiEncoder(r) || std::any_of(r.ambiguous.begin(), r.ambiguous.end(), [](const Ambiguity& a) {
           return a.chosen == "sphere_form" && (a.other == "phi_encoder" || a.other == "phi_radial_motion");
         });
}

// The design of KnownAndUnknown(): the setup of unknown orientation has a form of its own, which
// no pattern fixed on the sphere common to both setups explains, and within each setup the time
// of a reading is a function of its direction (a scan order), another one in each. A drift in
// time took that difference of the forms: probe_drift was added in the second round in seeds 2, 3
// and 4 (delta BIC -14.0, -33.5, -29.0), beside the Phi encoder error (seed 3: a Phi radial motion
// named with it). The transfer test did not judge it there: with the drift the unknown setup alone
// leaves the model loose, so the known one was not predicted. A drift must show beyond a pattern
// fixed on the sphere in each setup (its delta BIC there is +4.0, +4.0, +4.4): none is added,
// and one refused says why and is reported with that pattern as two explanations. Since that
// pattern also competes with the machine's effects, it explains more than the encoder error in
// the first round of these seeds (extended delta BIC -333 against -147 in seed 2): the encoder is
// named beside it (seed 3: the Phi radial motion, 5 lower than the encoder), nothing is added, and
// a drift judged beside the encoder is not reached.
TEST(TraceWithForm, AddsNoDriftForTheFormOfASetupOfUnknownOrientation) {
  for (const std::uint64_t seed : {2, 3, 4}) {
    const PointsData points = Simulate(KnownAndUnknown(seed));
    const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), TraceOptions{});
    ASSERT_FALSE(r.form.separable) << r.form.design;
    EXPECT_EQ(std::count(r.added.begin(), r.added.end(), Effect::kProbeDrift), 0) << "seed " << seed;
    EXPECT_TRUE(FoundOrNamedThePhiEncoderOrThePattern(r)) << "seed " << seed;
    for (const CandidateScore& c : r.candidates) {
      if (c.effect != Effect::kProbeDrift || c.sphere_form || c.note.find("qualifies") == std::string::npos) continue;
      EXPECT_NE(c.note.find("no more than a pattern fixed on the sphere would"), std::string::npos)
          << "seed " << seed << ": " << c.note;
    }
  }
}

// The same design with a true drift of 0.4 um beside the Phi encoder error: the drift shows beyond
// the pattern on each setup's sphere (delta BIC about -500) and is found; the Phi encoder error is
// found or named as without the drift. In seeds 1 and 3 the transfer test refused the drift in the
// first round: the known setup, measured before the unknown one, was predicted by a drift fitted to
// the unknown one's times alone, 1.1 um rms off. A setup outside the others' time span is not
// judged with a drift in the model.
TEST(TraceWithForm, FindsATrueDriftBesideTheFormOfASetupOfUnknownOrientation) {
  for (const std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    SimulationSpec spec = KnownAndUnknown(seed);
    spec.effects.model.terms.push_back({Effect::kProbeDrift, {{1, 0, false}}});
    spec.effects.values.push_back({0.4 * kMmPerUm});
    const PointsData points = Simulate(spec);
    const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), TraceOptions{});
    EXPECT_EQ(std::count(r.added.begin(), r.added.end(), Effect::kProbeDrift), 1) << "seed " << seed;
    EXPECT_TRUE(FoundOrNamedThePhiEncoderOrThePattern(r)) << "seed " << seed;
  }
}

// The design of KnownAndUnknown() without any effect of the machine: form28 alone. The pattern
// fixed on the sphere that competes with the effects was one common to both setups, which explains
// nothing of what differs between their forms: a Phi radial motion took the unknown setup's own
// form in seeds 1019 and 1071 (trace_study --false-additions, 38 of 500 runs). With a pattern for
// each set of form (the setups of known orientation, the one of unknown orientation) nothing is
// added, and the true effects of the design are still found or named beside what imitates them.
TEST(TraceWithForm, AddsNoMachineEffectForTheFormOfASetupOfUnknownOrientation) {
  for (const std::uint64_t seed : {1019, 1071}) {
    SimulationSpec spec = KnownAndUnknown(seed);
    spec.effects.model.terms.clear();
    spec.effects.values.clear();
    const PointsData points = Simulate(spec);
    const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), TraceOptions{});
    ASSERT_FALSE(r.form.separable) << r.form.design;
    EXPECT_TRUE(r.added.empty()) << "seed " << seed << ": " << InfoOf(r.added.front()).id;
  }
}

// The same seeds with a true Phi encoder error (10 arcsec once per turn) or a true Phi radial
// motion (0.3 um at 2 per turn) beside form28: each is found, or named beside the effect added in
// its place or beside the pattern on the sphere (the radial motion in both seeds, before and after).
TEST(TraceWithForm, FindsAPhiEffectBesideTheFormOfASetupOfUnknownOrientation) {
  for (const std::uint64_t seed : {1019, 1071}) {
    const PointsData encoder = Simulate(KnownAndUnknown(seed));
    const TraceResult e = TraceResidual(encoder, PaperOptions(), Calibrate(encoder, PaperOptions()), TraceOptions{});
    EXPECT_TRUE(FoundOrNamedThePhiEncoderOrThePattern(e)) << "seed " << seed;
    SimulationSpec spec = KnownAndUnknown(seed);
    spec.effects.model.terms = {{Effect::kPhiRadialMotion, {{2, 0, false}}}};
    spec.effects.values = {{0.3 * kMmPerUm}};
    const PointsData radial = Simulate(spec);
    const TraceResult r = TraceResidual(radial, PaperOptions(), Calibrate(radial, PaperOptions()), TraceOptions{});
    // Named: beside the effect added in its place, or beside the pattern on the sphere (nothing added).
    const bool named = std::any_of(r.ambiguous.begin(), r.ambiguous.end(), [&](const Ambiguity& a) {
      Effect chosen{};
      return a.other == "phi_radial_motion" &&
             (a.chosen == "sphere_form" || (EffectFromId(a.chosen, &chosen) &&
                                            std::find(r.added.begin(), r.added.end(), chosen) != r.added.end()));
    });
    EXPECT_TRUE(std::count(r.added.begin(), r.added.end(), Effect::kPhiRadialMotion) == 1 || named)
        << "seed " << seed;
  }
}

// Two placements, one at 2 mm and one with the sphere on the Theta axis, and a model of a Theta
// encoder error and a radial motion of the Theta spindle at twice per turn. On the axis the sphere
// turns about its own centre and the encoder error is not seen; at 2 mm alone the two are one
// signal. Each setup left out is predicted from a fit that does not determine the model: the
// transfer cannot be judged on this design (no rms, which would read as if the model did not
// transfer), the setups named, and the report says so.
TEST(LeaveOneSetupOut, CannotBeJudgedWhereTheOtherSetupsDoNotDetermineTheModel) {
  SimulationSpec spec;
  spec.seed = 2;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 0, 0)};
  spec.effects.model.terms = {{Effect::kThetaEncoder, {{2, 0, false}}}, {Effect::kThetaRadialMotion, {{2, 0, false}}}};
  spec.effects.values = {{5 * kRadPerArcsec}, {0.2 * kMmPerUm}};
  const PointsData points = Simulate(spec);
  TraceOptions twice_per_turn;
  twice_per_turn.harmonics = {2, 2};
  const TraceResult r = FitFixedEffects(points, PaperOptions(), Calibrate(points, PaperOptions()),
                                        {Effect::kThetaEncoder, Effect::kThetaRadialMotion}, twice_per_turn);
  EXPECT_EQ(r.after.loso_not_judged, (std::vector<int>{0, 1}));
  EXPECT_TRUE(std::isnan(r.after.loso_rms_um)) << r.after.loso_rms_um;
  EXPECT_TRUE(std::isnan(LeaveOneSetupOutRms(points, PaperOptions(), r.after.fit)));
  std::ostringstream text;
  WriteTraceText(text, r, nullptr);
  EXPECT_NE(text.str().find("leave one setup out: cannot be judged on this design"), std::string::npos) << text.str();
}

// The same design as KnownAndUnknown() with a drift of 0.4 um beside the Phi encoder error, and
// that model fitted: the drift is refitted over the time of the setup predicted, so the unknown
// setup alone, a part of the run whose times are a function of its directions, need not determine
// it (carried over from the unknown setup's times, the drift would be extrapolated to the known
// one's). The known setup is judged, and the model transfers to it within twice the noise
// (sigma_r 0.05 um; form28, which turns with the sphere, is not in the model).
TEST(LeaveOneSetupOut, ADriftIsRefittedOverTheTimeOfTheSetupPredicted) {
  SimulationSpec spec = KnownAndUnknown(1);
  spec.effects.model.terms.push_back({Effect::kProbeDrift, {{1, 0, false}}});
  spec.effects.values.push_back({0.4 * kMmPerUm});
  const PointsData points = Simulate(spec);
  TraceOptions once_per_turn;
  once_per_turn.harmonics = {1, 1};
  const TraceResult r = FitFixedEffects(points, PaperOptions(), Calibrate(points, PaperOptions()),
                                        {Effect::kPhiEncoder, Effect::kProbeDrift}, once_per_turn);
  EXPECT_TRUE(r.after.loso_not_judged.empty());
  EXPECT_LT(r.after.loso_rms_um, 0.1);
}

// Five placements that separate the form (the eccentricity points another way on the body in
// each), a form of degrees 2..8, a Theta encoder error and a probe drift: the model the trace
// chooses transfers from four setups to the fifth at the noise (sigma_r 0.05 um), the seven
// errors alone do not.
TEST(LeaveOneSetupOut, TheChosenModelTransfersWhereTheDesignSeparatesTheForm) {
  SimulationSpec spec;
  spec.seed = 3;
  spec.centers_mm = std::vector<Eigen::Vector3d>(5, Eigen::Vector3d(2.0, 0.0, 0.0));
  spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {0, 0, 180}}, {3, {90, 0, 0}}, {4, {0, 90, 0}}};
  spec.scan_orders = {
      {1, ScanOrder::kSerpentine}, {2, ScanOrder::kColumns}, {3, ScanOrder::kReversed}, {4, ScanOrder::kShuffled}};
  spec.effects.model.terms = {{Effect::kThetaEncoder, {{3, 0, false}}}, {Effect::kProbeDrift, {{1, 0, false}}}};
  spec.effects.values = {{5 * kRadPerArcsec}, {0.4 * kMmPerUm}};
  spec.effects.form = Form28();
  const PointsData points = Simulate(spec);
  const TraceResult r = TraceResidual(points, PaperOptions(), Calibrate(points, PaperOptions()), TraceOptions{});
  ASSERT_EQ(std::set<Effect>(r.added.begin(), r.added.end()),
            std::set<Effect>({Effect::kThetaEncoder, Effect::kProbeDrift}));
  EXPECT_GT(r.before.loso_rms_um, 2.0 * 0.05);
  EXPECT_LT(r.after.loso_rms_um, 1.15 * 0.05);
  EXPECT_GE(r.after.loso_rms_um, r.after.fit.calibration.rms_um);  // a prediction, not a fit
}

}  // namespace
}  // namespace sph
