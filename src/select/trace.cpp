#include "sph/select/trace.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <system_error>

#include <Eigen/QR>

#include "effect_fit_rows.hpp"
#include "fit_problem.hpp"
#include "pair_separation.hpp"
#include "sph/core/error.hpp"
#include "sph/core/gum.hpp"
#include "sph/core/setup_checks.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/parallel.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"
#include "sph/select/identifiability.hpp"
#include "structure_jacobian.hpp"

namespace sph {
namespace {

using internal::Format;
using internal::ParallelFor;

bool IsThetaMachine(Effect e) {
  return e == Effect::kThetaEncoder || e == Effect::kThetaRadialMotion || e == Effect::kThetaAxialMotion ||
         e == Effect::kThetaTiltMotion;
}
bool IsPhiMachine(Effect e) {
  return e == Effect::kPhiEncoder || e == Effect::kPhiWobble || e == Effect::kPhiRadialMotion ||
         e == Effect::kPhiAxialMotion;
}
bool IsThetaMotion(Effect e) { return e == Effect::kThetaRadialMotion || e == Effect::kThetaAxialMotion; }
bool IsPair(Effect a, Effect b, Effect x, Effect y) { return (a == x && b == y) || (a == y && b == x); }
bool IsProbe(Effect e) { return e == Effect::kProbeGain || e == Effect::kProbeNonlinearity; }

// The measurement that tells two effects apart, from how each maps onto the readings.
std::string SeparateBy(Effect a, Effect b) {
  if (a == Effect::kProbeDrift || b == Effect::kProbeDrift) {
    return "repeated reference points: return to one position at the start, middle and end of the run, or measure "
           "the pattern in another order (drift follows time, the other follows the position)";
  }
  if (IsPair(a, b, Effect::kProbeIncidence, Effect::kProbeGain)) {
    return "a second sphere of another radius (sphere_radius_mm@<setup>): at any eccentricity e both leave a term "
           "in sin^2 of the angle on the sphere proportional to e^2, the gain's as 1/R, the incidence's as 1/R^2";
  }
  if (a == Effect::kProbeIncidence || b == Effect::kProbeIncidence) {
    return "a second sphere position at another eccentricity: the probe's incidence error grows with its square "
           "(sin psi reaches about e / R0), a machine error's signal on the sphere in proportion to it or not at all";
  }
  if ((a == Effect::kThetaTiltMotion && IsThetaMotion(b)) || (b == Effect::kThetaTiltMotion && IsThetaMotion(a))) {
    return "a second sphere position at another height along the Theta axis or another eccentricity: a tilt of the "
           "spindle moves the sphere by its lever (the centre's distance from the pivot), a radial or axial motion by "
           "the same amount wherever the sphere sits";
  }
  if (IsPair(a, b, Effect::kPhiWobble, Effect::kPhiRadialMotion)) {
    return "a larger eccentricity: a tilt of the Phi axis about its pivot at L shifts the probe line by L w along the "
           "beam as a radial motion does, and besides turns it across the surface, which shows only through the "
           "eccentricity (e w against L w)";
  }
  if (IsThetaMachine(a) && IsThetaMachine(b)) {
    return "a second sphere position at another eccentricity or azimuth: an encoder error moves the probed point "
           "along the surface and shows only through the eccentricity, a spindle motion moves the sphere along the "
           "probe line whatever the eccentricity";
  }
  if (IsPhiMachine(a) && IsPhiMachine(b)) {
    return "a second sphere position at another height along the Theta axis, which changes the lever of a Phi axis "
           "tilt but not that of a Phi positioning error";
  }
  if (IsProbe(a) && IsProbe(b)) {
    return "another eccentricity, which changes the range the probe works over";
  }
  return "a second sphere position (another eccentricity or azimuth), which changes how machine errors map onto the "
         "readings";
}

// The extended BIC's charge for the components `term` keeps of those its effect's default term
// searched (FitCandidate() keeps only the separable and significant ones).
double SearchPenalty(const EffectTerm& term, const TraceOptions& trace_options) {
  const auto searched = DefaultTerm(term.effect, trace_options.harmonics, trace_options.drift_order).components.size();
  return SubsetSearchPenalty(static_cast<int>(searched), static_cast<int>(term.components.size()));
}

// The readings a trace fits and their table, built once for every candidate, fold and refit.
struct Readings {
  PointsData points;
  internal::ReadingTable table;
  explicit Readings(PointsData p) : points(std::move(p)), table(points) {}
};

double CrossValidated(const Readings& data, const CalibrationOptions& options, const EffectModel& model,
                      const EffectFitStart& start, int folds, std::uint64_t seed);

// The fewest samples that a fit of the cross-validation fits (CrossValidated(): each fold holds
// every `folds`-th sample of each setup, the first fold the most), and the most a fold leaves out.
struct FoldSizes {
  std::size_t fewest_fitted = 0, most_left_out = 0;
};
FoldSizes FoldSizesOf(const PointsData& points, int folds) {
  std::map<int, std::size_t> of_setup;
  for (const Sample& s : points.samples) ++of_setup[s.setup];
  FoldSizes f;
  const auto k = static_cast<std::size_t>(std::max(folds, 1));
  for (const auto& [setup, n] : of_setup) f.most_left_out += (n + k - 1) / k;
  f.fewest_fitted = points.samples.size() - f.most_left_out;
  return f;
}

// Throws sph::Error, in the terms of the file, when the cross-validation of a model of n_params
// parameters (`what` they are) cannot fit them: a fit needs more samples than parameters. The
// seven-error calibration alone needs more than base_params.
void CheckFoldsCanFit(const PointsData& points, int folds, int n_params, const std::string& what, int base_params) {
  const FoldSizes f = FoldSizesOf(points, folds);
  if (f.fewest_fitted > static_cast<std::size_t>(n_params)) return;
  std::string needed;
  if (points.SetupIds().size() == 1) {  // one setup: the samples the folds would need
    const auto k = static_cast<std::size_t>(std::max(folds, 1));
    std::size_t n = points.samples.size();
    while (n - (n + k - 1) / k <= static_cast<std::size_t>(n_params)) ++n;
    needed = ": at least " + std::to_string(n) + " samples are needed";
  }
  throw Error(points.source + ": " + std::to_string(points.samples.size()) + " samples are too few to trace the " +
              "residual: its " + std::to_string(folds) + "-fold cross-validation fits " + what + " (" +
              std::to_string(n_params) + " parameters) to the samples outside each fold, here as few as " +
              std::to_string(f.fewest_fitted) + " (a fold leaves out up to " + std::to_string(f.most_left_out) +
              "), and a fit needs more samples than parameters" + needed +
              "; the seven errors alone (--no-trace) need more than " + std::to_string(base_params));
}

std::vector<double> LeaveOneSetupOutErrors(const Readings& data, const CalibrationOptions& options,
                                           const EffectFit& fit, std::set<int>* loose = nullptr);
double RmsUmOf(const std::vector<double>& errors_mm);
std::vector<double> WithoutSetups(std::vector<double> errors_mm, const std::set<int>& setups, const PointsData& points);

// Unit directions from the fitted centre to each probed point, at the readings `expected_r_mm`
// where the fit's residual vanishes (residual_structure.hpp): the measured r would carry the noise
// that the residual is into the directions.
std::vector<Eigen::Vector3d> Directions(const PointsData& points, const CalibrationOptions& options,
                                        const EffectFit& fit, const std::vector<double>& expected_r_mm) {
  PointsData expected = points;
  for (std::size_t i = 0; i < expected.samples.size(); ++i) expected.samples[i].r_mm = expected_r_mm[i];
  std::vector<Eigen::Vector3d> d = OffsetsFromCentre(expected, options, fit);
  for (Eigen::Vector3d& v : d) v.normalize();
  return d;
}

// What the residual analyses need of a traced fit.
FitResiduals ResidualsOfTraced(const Readings& data, const TracedFit& t, const JacobianBlocks& jacobian) {
  return {data.points, t.fit.calibration.residuals_mm, t.expected_r_mm, jacobian, t.fit.model.reference, t.directions};
}

TracedFit Analysed(EffectFit fit, const Readings& data, const CalibrationOptions& options,
                   const TraceOptions& trace_options) {
  TracedFit t;
  t.expected_r_mm = ExpectedReadings(data.points, options, fit);
  t.directions = Directions(data.points, options, fit, t.expected_r_mm);
  t.fit = std::move(fit);
  const internal::StructureJacobian jacobian(data.table, options, t.fit, t.expected_r_mm);
  t.factor = FactorResidualStructure(ResidualsOfTraced(data, t, jacobian));
  t.structure = AnalyseResidualStructure(t.factor);
  t.cv_rms_um =
      CrossValidated(data, options, t.fit.model, EffectFitStart::From(t.fit), trace_options.folds, trace_options.seed);
  std::set<int> loose;
  const std::vector<double> errors = LeaveOneSetupOutErrors(data, options, t.fit, &loose);
  t.loso_rms_um = RmsUmOf(errors);
  t.loso_errors_mm = WithoutSetups(errors, loose, data.points);
  return t;
}

// A component that FitCandidate() leaves out of the candidate term, and why.
struct Drop {
  int component;       // index into the term's components as fitted
  bool not_separable;  // its VIF is above TraceOptions::max_vif (else: its t below min_t)
};

// The rule of FitCandidate() over the candidate's `size` components (parameters offset.. of the
// fit `rep`, values `values`): while a VIF is above max_vif the component with the largest is
// dropped, else while a |t| is below min_t the one with the smallest. The first drop is decided
// on the fit itself; the ones after it on the linearised problem at the fit, where refitting
// without component j is holding it at zero: the covariance C is downdated by C e_j e_j^T C / C_jj,
// the values by C e_j x_j / C_jj, the residual sum of squares grows by x_j^2 / C_jj in units of
// sigma^2 (and the degrees of freedom by one), and each VIF scales with its C_kk. The caller
// refits once without them all and applies the rule to that fit again.
std::vector<Drop> Eliminate(const ObservabilityReport& rep, std::vector<double> values, int offset, int size,
                            double rows, const TraceOptions& trace_options) {
  std::vector<Drop> drops;
  std::vector<bool> alive(static_cast<std::size_t>(size), true);
  // A component held at a value given (CalibrationOptions::fixed) stays: it is known, not fitted.
  for (int j = 0; j < size; ++j) {
    if (rep.IsHeld(offset + j)) alive[static_cast<std::size_t>(j)] = false;
  }
  if (std::find(alive.begin(), alive.end(), true) == alive.end()) return drops;
  Eigen::MatrixXd c = rep.covariance;
  const double dof = rows - static_cast<double>(c.rows());
  double rss_ratio = 1.0;  // (residual sum of squares) / (sigma^2 dof) of the fit
  for (;;) {
    const bool exact = drops.empty();
    int worst_vif = -1, weakest = -1;
    double vif_max = 0.0, t_min = std::numeric_limits<double>::infinity();
    const double sigma_ratio = std::sqrt(rss_ratio * dof / (dof + static_cast<double>(drops.size())));
    for (int j = 0; j < size; ++j) {
      if (!alive[static_cast<std::size_t>(j)]) continue;
      const Eigen::Index col = offset + j;
      const double vif = exact ? rep.vif(col) : rep.vif(col) * c(col, col) / rep.covariance(col, col);
      if (!(vif <= vif_max)) {  // NaN and inf count as worst
        vif_max = std::isfinite(vif) ? vif : std::numeric_limits<double>::infinity();
        worst_vif = j;
      }
      const double std = exact ? rep.std(col) : std::sqrt(std::max(c(col, col), 0.0)) * sigma_ratio;
      const double t = std::abs(values[static_cast<std::size_t>(j)]) / std;
      if (!(t >= t_min)) {
        t_min = std::isfinite(t) ? t : 0.0;
        weakest = j;
      }
    }
    int drop = -1;
    if (vif_max > trace_options.max_vif) {
      drop = worst_vif;
    } else if (t_min < trace_options.min_t) {
      drop = weakest;
    }
    if (drop < 0) break;
    drops.push_back({drop, vif_max > trace_options.max_vif});
    // Downdate, where the linearised problem is defined.
    const Eigen::Index k = offset + drop;
    const double ckk = c(k, k);
    if (!c.allFinite() || !(ckk > 0.0)) break;
    const double x = values[static_cast<std::size_t>(drop)];
    for (int j = 0; j < size; ++j) {
      values[static_cast<std::size_t>(j)] -= c(offset + j, k) * x / ckk;
    }
    rss_ratio += x * x / ckk / dof;
    const Eigen::VectorXd ck = c.col(k);
    c.noalias() -= ck * ck.transpose() / ckk;
    alive[static_cast<std::size_t>(drop)] = false;
    if (std::find(alive.begin(), alive.end(), true) == alive.end()) break;
  }
  return drops;
}

// Whether the options hold parameter `name` or give it a prior.
bool Told(const CalibrationOptions& options, const std::string& name) {
  return std::any_of(options.fixed.begin(), options.fixed.end(),
                     [&](const FixedParameter& f) { return f.name == name; }) ||
         std::any_of(options.priors.begin(), options.priors.end(),
                     [&](const ParameterPrior& p) { return p.name == name; });
}

// `names` separated by spaces; past the first eight, their count ("... and 13 more").
std::string Listed(const std::vector<std::string>& names) {
  constexpr std::size_t kNamed = 8;
  std::string s;
  for (std::size_t i = 0; i < std::min(names.size(), kNamed); ++i) s += (i == 0 ? "" : " ") + names[i];
  if (names.size() > kNamed) s += " and " + std::to_string(names.size() - kNamed) + " more";
  return s;
}

// The model of `current` with `term` added, fitted; components that the data cannot separate or
// do not show are left out (Eliminate(): after each fit, all that the rule drops at it, then
// refitted). The last term of the returned fit is the candidate (absent when nothing of it is left).
EffectFit FitCandidate(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                       EffectTerm term, const TraceOptions& trace_options, std::string* note) {
  EffectModel model = current.model;
  model.terms.push_back(term);
  EffectFitStart start = EffectFitStart::From(current);
  start.values.emplace_back(static_cast<std::size_t>(term.size()), 0.0);
  std::vector<std::string> left_out_vif, left_out_t;
  auto short_name = [](const EffectTerm& t, int j) {
    return t.ParamName(static_cast<std::size_t>(j)).substr(std::string(t.info().id).size() + 1);
  };
  // Components that the linearised problem at the start cannot separate are left out before any
  // fit: the fit would only crawl along their valley.
  for (;;) {
    EffectFit at_start;
    at_start.model = model;
    at_start.values = start.values;
    at_start.form_values = start.form_values;
    at_start.calibration.geometry = start.geometry;
    at_start.calibration.centers_mm = start.centers_mm;
    at_start.calibration.setup_ids = current.calibration.setup_ids;
    at_start.n_params = current.n_params + model.terms.back().size();
    const NormalInverse inv = internal::NormalInverseAt(data.table, options, at_start);
    EffectTerm& cand = model.terms.back();
    const int offset = at_start.TermOffset(model.terms.size() - 1);
    int worst = -1;
    double vif_max = trace_options.max_vif;
    for (int j = 0; j < cand.size(); ++j) {
      // A component held or informed (CalibrationOptions::fixed, priors) is known beyond these
      // readings: the fit, not the linearised problem without it, decides.
      if (Told(options, cand.ParamName(static_cast<std::size_t>(j)))) continue;
      const auto col = static_cast<Eigen::Index>(offset + j);
      const double vif = inv.in_null[static_cast<std::size_t>(col)]
                             ? std::numeric_limits<double>::infinity()
                             : inv.inverse(col, col) / (inv.scale(col) * inv.scale(col));
      if (!(vif <= vif_max)) {
        vif_max = std::isfinite(vif) ? vif : std::numeric_limits<double>::infinity();
        worst = j;
      }
    }
    if (worst < 0) break;
    left_out_vif.push_back(short_name(cand, worst));
    cand.components.erase(cand.components.begin() + worst);
    start.values.back().erase(start.values.back().begin() + worst);
    if (cand.components.empty()) {
      *note = "no component is separable from the other parameters";
      return current;
    }
  }
  const std::size_t fewest = FoldSizesOf(data.points, trace_options.folds).fewest_fitted;
  if (static_cast<std::size_t>(current.n_params + model.terms.back().size()) >= fewest) {
    *note = "not tried: with its " + std::to_string(model.terms.back().size()) + " component(s) the model has " +
            std::to_string(current.n_params + model.terms.back().size()) + " parameters, and a cross-validation " +
            "fold fits as few as " + std::to_string(fewest) + " samples";
    return current;
  }
  for (;;) {
    EffectFit fit = internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
    EffectTerm& cand = model.terms.back();
    const std::vector<Drop> drops =
        Eliminate(fit.calibration.analysis, fit.values.back(), fit.TermOffset(model.terms.size() - 1), cand.size(),
                  static_cast<double>(data.points.samples.size()), trace_options);
    if (drops.empty()) {
      *note = "";
      if (!left_out_vif.empty()) *note += "left out, not separable from the other parameters: " + Listed(left_out_vif);
      if (!left_out_t.empty()) {
        *note += std::string(note->empty() ? "" : "; ") + "left out, not significant: " + Listed(left_out_t);
      }
      return fit;
    }
    start = EffectFitStart::From(fit);
    std::vector<int> dropped;
    for (const Drop& d : drops) {
      (d.not_separable ? left_out_vif : left_out_t).push_back(short_name(cand, d.component));
      dropped.push_back(d.component);
    }
    std::sort(dropped.rbegin(), dropped.rend());
    for (const int j : dropped) {
      cand.components.erase(cand.components.begin() + j);
      start.values.back().erase(start.values.back().begin() + j);
    }
    if (cand.components.empty()) {
      model.terms.pop_back();
      start.values.pop_back();
      EffectFit without = current;
      *note = left_out_vif.empty() ? "no component is significant"
                                   : "no component is both separable from the other parameters and significant";
      return without;
    }
  }
}

// Whether the design separates the sphere's form from the machine (the sphere measured in at least
// two known orientations), and the highest degree the pattern resolves: a degree-L harmonic has L
// cycles around the sphere, so it needs more than 2L points on each ring and more than L rings.
FormSelection FormDesign(const PointsData& points, const TraceOptions& trace_options) {
  FormSelection f;
  std::vector<Eigen::Matrix3d> orientations;
  int own = 0;  // setups whose form is not the reference sphere's in a known orientation
  for (const int id : points.SetupIds()) {
    if (!points.header.FormKey(id).empty()) {
      ++own;
      continue;
    }
    const auto it = points.header.mount_rotations.find(id);
    const Eigen::Matrix3d r = it == points.header.mount_rotations.end() ? Eigen::Matrix3d::Identity()
                                                                        : MountRotationMatrix(*it->second.rotation_deg);
    bool seen = false;
    for (const Eigen::Matrix3d& o : orientations) seen |= (o - r).norm() < 1e-9;
    if (!seen) orientations.push_back(r);
  }
  std::vector<double> thetas, phis;
  for (const Sample& smp : points.samples) {
    thetas.push_back(std::round(smp.theta_deg * 1e6));
    phis.push_back(std::round(smp.phi_deg * 1e6));
  }
  auto distinct = [](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    return static_cast<int>(std::unique(v.begin(), v.end()) - v.begin());
  };
  const int resolved = std::min(distinct(phis) - 1, (distinct(thetas) - 1) / 2);
  f.degree_limit = std::min(trace_options.form_degree_max, resolved);
  // No higher than the cross-validation's folds can fit beside the seven errors and the centres.
  const int base_params = kNumScmsParams + 3 * static_cast<int>(points.SetupIds().size());
  const auto fewest = static_cast<int>(FoldSizesOf(points, trace_options.folds).fewest_fitted);
  int fitted = 1;
  while (fitted < f.degree_limit &&
         base_params + FormModelOf(points, FormTermsOfDegrees(2, fitted + 1)).NumParams() < fewest) {
    ++fitted;
  }
  const bool few = fitted < f.degree_limit;
  f.degree_limit = fitted;
  f.separable = orientations.size() >= 2 && f.degree_limit >= 2;
  const std::string unknown_note =
      own > 0 ? "; " + std::to_string(own) +
                    " setup(s) of unknown orientation or on another sphere, with forms of their own"
              : "";
  if (f.separable) {
    f.design = "the sphere measured in " + std::to_string(orientations.size()) +
               " known orientations on its mount: its form (turning with it) is fitted with the machine, degrees 2 "
               "to at most " +
               std::to_string(f.degree_limit) + unknown_note;
  } else if (orientations.size() < 2) {
    f.design = "the sphere in one known orientation" + unknown_note +
               ": a form of the sphere cannot be told from a function of the direction; it competes with the effects "
               "as a pattern fixed on the sphere";
  } else {
    f.design = few ? "the cross-validation's folds (as few as " + std::to_string(fewest) +
                         " samples) cannot fit a form of degree 2 or more beside the seven errors and the centres"
                   : "the pattern resolves no form of degree 2 or more";
  }
  return f;
}

// Which form terms of degrees 2..degree_limit the design cannot tell from the seven errors, the
// centres and the candidates of `pool` (linearised at `base`), in words. They stay in the search
// (the form is fitted before any effect, so no machine term they are confounded with is in the
// model with them); the report says that their split with the machine is not known.
void ConfoundedFormTerms(const Readings& data, const CalibrationOptions& options, const EffectFit& base,
                         const std::vector<Effect>& pool, const TraceOptions& trace_options, FormSelection* sel) {
  EffectModel machine;
  machine.reference = base.model.reference;
  int judged = base.n_params + FormModelOf(data.points, FormTermsOfDegrees(2, sel->degree_limit)).NumParams();
  for (const Effect e : pool) {
    machine.terms.push_back(DefaultTerm(e, trace_options.harmonics, trace_options.drift_order));
    judged += machine.terms.back().size();
  }
  if (data.points.samples.size() <= static_cast<std::size_t>(judged)) {
    sel->design += "; which of its terms the machine's effects would confound is not judged: " +
                   std::to_string(data.points.samples.size()) + " readings are too few for the " +
                   std::to_string(judged) + " parameters of the form and every candidate effect";
    return;
  }
  const FormIdentifiability id =
      IdentifyForm(data.points, options, machine, EffectFitStart::From(base), FormTermsOfDegrees(2, sel->degree_limit));
  for (const ConfoundedCombination& c : id.combinations) sel->confounded.push_back(c.words);
  if (!id.confounded.empty()) {
    std::string names;
    for (const FormTerm& t : id.confounded) {
      names += (names.empty() ? "" : " ") + ("S(" + std::to_string(t.l) + "," + std::to_string(t.m) + ")");
    }
    sel->design += "; " + names +
                   " cannot be told from the machine by this design: fitted as the sphere's, their split is not known";
  }
}

// The fit of `current`'s model with the sphere's form of degrees 2..L, for the L that minimises
// the extended BIC (BIC + 2 ln N, N the degrees searched), or the model without a form when no L
// lowers it by min_delta_bic. sel->delta_ebic gets each degree's score.
EffectFit SelectFormDegree(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                           const TraceOptions& trace_options, FormSelection* sel) {
  EffectModel plain = current.model;
  plain.form = FormModel{};
  EffectFitStart start = EffectFitStart::From(current);
  start.form_values.clear();
  EffectFit none = current.model.form.Empty()
                       ? current
                       : internal::FitEffectsRows(data.points, data.table, nullptr, options, plain, start);
  const double penalty = 2.0 * std::log(static_cast<double>(std::max(1, sel->degree_limit - 1)));
  EffectFit best = none;
  double best_score = none.Bic();
  sel->degree_max = 0;
  sel->delta_ebic.clear();
  for (int l = 2; l <= sel->degree_limit; ++l) {
    EffectModel model = plain;
    model.form = FormModelOf(data.points, FormTermsOfDegrees(2, l));
    EffectFit fit =
        internal::FitEffectsRows(data.points, data.table, nullptr, options, model, EffectFitStart::From(none));
    const double score = fit.Bic() + penalty;
    sel->delta_ebic.emplace_back(l, score - none.Bic());
    if (!fit.calibration.converged) continue;
    if (score - none.Bic() <= -trace_options.min_delta_bic && score < best_score) {
      best_score = score;
      best = std::move(fit);
      sel->degree_max = l;
    }
  }
  return best;
}

// Whether the sphere sat in one place for every setup (their centres within 10 um): the probe
// reading is then, like the time of a single pass, a function of the direction on the sphere, and
// a smooth one (to first order e . n, e the eccentricity).
bool OnePlacement(const EffectFit& fit) {
  const std::vector<Eigen::Vector3d>& c = fit.calibration.centers_mm;
  return std::all_of(c.begin(), c.end(), [&](const Eigen::Vector3d& x) { return (x - c.front()).norm() <= 0.010; });
}

// Whether the candidate follows a variable that a pattern fixed on the sphere is not (the time for
// probe_drift, the probe reading for the probe terms) and the residual shows its functions of that
// variable beyond any form of degree 2..5: the linearised BIC of J, every such harmonic and the
// term's powers against J and the harmonics alone falls by at least min_delta_bic. Never for a
// probe term with the sphere in one placement: a power of the reading is then a form of low degree
// (u^k of degree about k), and what it shows beyond degrees 2..5 is a higher degree of the form
// (the sphere's own, of degree 6 and more) that the reading's small higher terms happen to follow.
bool ShownBeyondSphere(const CandidateScore& c, const StructureFactor& factor, bool one_placement,
                       const TraceOptions& trace_options) {
  const std::string v = InfoOf(c.effect).variable;
  if ((v != "t" && v != "r") || c.term.components.empty()) return false;
  if (v == "r" && one_placement) return false;
  std::vector<int> functions;
  for (const EffectComponent& comp : c.term.components) functions.push_back(comp.order - 1);
  return DeltaBicBeyondSphere(factor, v, functions) <= -trace_options.min_delta_bic;
}

// The measurement that separates effect e from a form of the sphere when the sphere was measured
// in one placement.
std::string SeparateFromForm(Effect e) {
  if (e == Effect::kProbeDrift) {
    return "the pattern measured a second time in another order (reversed or shuffled), so that time is no "
           "function of the direction on the sphere, or the sphere turned on its mount";
  }
  if (InfoOf(e).harmonic) {  // an error of the machine's axes
    return "the sphere turned on its mount (a form turns with the sphere, an error of the machine stays with the "
           "machine), or a second setup at another eccentricity";
  }
  return "a second setup at another eccentricity (the probe then works over another range) or with the sphere turned "
         "on its mount (a form turns with the sphere)";
}

// Whether the structure test of the variable effect e follows (time or probe reading) is significant.
bool ShownByItsVariable(Effect e, const ResidualStructure& structure, const TraceOptions& trace_options) {
  const std::string v = InfoOf(e).variable;
  if (v != "t" && v != "r") return false;
  for (const StructureGroup& g : structure.groups) {
    if (g.variable == v) return g.p_value < trace_options.structure_p;
  }
  return false;
}

std::vector<Unexplained> RemainingStructure(const ResidualStructure& s, const TraceOptions& trace_options) {
  std::vector<Unexplained> out;
  if (!(s.all.p_value < trace_options.structure_p)) return out;
  std::vector<const StructureGroup*> groups;
  for (const StructureGroup& g : s.groups) {
    if (g.p_value < trace_options.structure_p) groups.push_back(&g);
  }
  std::sort(groups.begin(), groups.end(),
            [](const StructureGroup* a, const StructureGroup* b) { return a->explained_rms_um > b->explained_rms_um; });
  for (const StructureGroup* g : groups) {
    Unexplained u;
    u.variable = g->variable;
    u.rms_um = g->explained_rms_um;
    u.p_value = g->p_value;
    const std::string what =
        g->variable == "sphere" ? "a pattern fixed on the sphere (its own form error, or an effect outside the library)"
                                : "structure that follows " + g->variable + " (" + g->description + ")";
    u.description = what + ", " + Format("%.3g", g->explained_rms_um) + " um RMS; strongest " + g->strongest + " (" +
                    Format("%.3g", g->strongest_rms_um) + " um RMS alone)";
    out.push_back(u);
  }
  if (out.empty()) {
    Unexplained u;
    u.variable = "all";
    u.rms_um = s.all.explained_rms_um;
    u.p_value = s.all.p_value;
    u.description = "structure that no single variable explains, " + Format("%.3g", s.all.explained_rms_um) + " um RMS";
    out.push_back(u);
  }
  return out;
}

// What the probe and drift terms of a trace of `all` are normalised by.
EffectReference ReferenceOf(const PointsData& all, const TraceOptions& trace_options) {
  const EffectReference of_data = EffectReferenceOf(all.samples);
  return trace_options.probe_range_mm ? WithProbeRange(of_data, *trace_options.probe_range_mm) : of_data;
}

// The seven-error calibration `base` as a fit with no effects over the readings it kept (`data`):
// its solution, residuals and analysis as they are, not solved a second time.
EffectFit FitNone(const Readings& data, const CalibrationResult& base, const EffectReference& reference,
                  const TraceOptions& trace_options) {
  EffectFit fit;
  fit.model.reference = reference;
  fit.model.phi_wobble_pivot_mm = trace_options.phi_wobble_pivot_mm;
  fit.calibration = base;
  CalibrationResult& kept = fit.calibration;
  if (!base.outliers.empty()) {  // base's residuals cover every sample: keep those of `data`
    std::vector<bool> out(base.residuals_mm.size(), false);
    for (const Outlier& o : base.outliers) out[o.sample] = true;
    kept.residuals_mm.clear();
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (!out[i]) kept.residuals_mm.push_back(base.residuals_mm[i]);
    }
    kept.outliers.clear();  // indices into `all`; `data` has none
  }
  if (kept.residuals_mm.size() != data.table.size()) {
    throw Error(data.points.source + ": the calibration's residuals do not match its readings");
  }
  for (double r : kept.residuals_mm) fit.rss_mm2 += r * r;
  fit.n_params = kNumScmsParams + 3 * static_cast<int>(kept.centers_mm.size());
  return fit;  // rms and peak-to-valley: base's, of the readings kept
}

// The readings of `all` that are outliers under `fit` (the rule of Calibrate()), as indices.
std::vector<std::size_t> OutliersUnder(const PointsData& all, const CalibrationOptions& options, const EffectFit& fit) {
  std::vector<int> setup;
  setup.reserve(all.samples.size());
  for (const Sample& s : all.samples) setup.push_back(s.setup);
  const std::vector<bool> out = RobustOutliers(EffectResiduals(all, options, fit), setup, options.outlier_sigma);
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (out[i]) idx.push_back(i);
  }
  return idx;
}

PointsData Without(const PointsData& points, const std::vector<std::size_t>& outliers) {
  CalibrationResult r;
  for (std::size_t i : outliers) r.outliers.push_back({i, 0.0});
  return WithoutOutliers(points, r);
}

// The seven-error calibration left out readings as outliers. Those that carry an effect the seven
// errors lack are no outliers under the final model: they are judged again under it and the model
// refitted on the readings it keeps, until the set no longer changes. The final model's result then
// names its outliers and says so.
void RejudgeOutliers(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
                     const TraceOptions& trace_options, TracedFit& after) {
  std::vector<std::size_t> outliers;
  for (const Outlier& o : base.outliers) outliers.push_back(o.sample);
  if (options.LeavesOutOutliers()) {
    for (int round = 0; round < 5; ++round) {
      const std::vector<std::size_t> judged = OutliersUnder(all, options, after.fit);
      if (judged == outliers) break;
      outliers = judged;
      const Readings kept(Without(all, outliers));
      EffectFitStart start = EffectFitStart::From(after.fit);
      after = Analysed(internal::FitEffectsRows(kept.points, kept.table, nullptr, options, after.fit.model, start),
                       kept, options, trace_options);
    }
  }
  CalibrationResult& cal = after.fit.calibration;
  const std::vector<double> residuals = EffectResiduals(all, options, after.fit);
  cal.outliers.clear();
  for (std::size_t i : outliers) cal.outliers.push_back({i, residuals[i] * kUmPerMm});
  if (!outliers.empty()) {
    cal.warnings.insert(cal.warnings.begin(), std::to_string(outliers.size()) +
                                                  " outlier(s) left out of the fit under the final model: " +
                                                  DescribeOutliers(all, cal.outliers));
  }
  if (outliers.size() < base.outliers.size()) {
    cal.warnings.push_back(std::to_string(base.outliers.size() - outliers.size()) +
                           " reading(s) that the seven-error fit left out as outliers fit the final model and are "
                           "used again");
  }
}

}  // namespace

namespace {

double CrossValidated(const Readings& data, const CalibrationOptions& options, const EffectModel& model,
                      const EffectFitStart& start, int folds, std::uint64_t seed) {
  const std::size_t m = data.points.samples.size();
  // Folds within each setup, so that every fold leaves every setup points to fit its centre.
  std::map<int, std::vector<std::size_t>> of_setup;
  for (std::size_t i = 0; i < m; ++i) of_setup[data.points.samples[i].setup].push_back(i);
  gum::Random rng(seed);
  std::vector<int> fold_of(m);
  for (auto& [setup, rows] : of_setup) {
    rng.Shuffle(rows);
    for (std::size_t k = 0; k < rows.size(); ++k)
      fold_of[rows[k]] = static_cast<int>(k % static_cast<std::size_t>(folds));
  }
  CalibrationOptions quick = options;
  quick.analyse = false;
  double sum2 = 0.0;
  std::vector<bool> fold(m), others(m);  // fitted without the fold, then predicted on it
  for (int f = 0; f < folds; ++f) {
    bool any = false;
    for (std::size_t i = 0; i < m; ++i) {
      fold[i] = fold_of[i] == f;
      others[i] = !fold[i];
      any |= fold[i];
    }
    if (!any) continue;
    const EffectFit fit = internal::FitEffectsRows(data.points, data.table, &fold, quick, model, start);
    const std::vector<double> e = internal::ResidualsAt(data.table, &others, options, fit, data.points.source);
    for (std::size_t i = 0; i < m; ++i) {
      if (fold[i]) sum2 += e[i] * e[i];
    }
  }
  return std::sqrt(sum2 / static_cast<double>(m)) * kUmPerMm;
}

// The readings of setup `k` of `fit` (rows not in `others`) under `fit` with that setup's centre
// refitted alone, by Gauss-Newton with a forward-difference Jacobian (the model's own residuals,
// so every effect and the form are in it); their residuals [mm], table-indexed (the others 0).
std::vector<double> WithOwnCentre(const Readings& data, const std::vector<bool>& others,
                                  const CalibrationOptions& options, EffectFit fit, std::size_t k) {
  constexpr double kStepMm = 1e-6;
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < others.size(); ++i) {
    if (!others[i]) rows.push_back(i);
  }
  std::vector<double> e = internal::ResidualsAt(data.table, &others, options, fit, data.points.source);
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::MatrixXd j(static_cast<Eigen::Index>(rows.size()), 3);
    Eigen::VectorXd r(static_cast<Eigen::Index>(rows.size()));
    for (std::size_t q = 0; q < rows.size(); ++q) r(static_cast<Eigen::Index>(q)) = e[rows[q]];
    for (int c = 0; c < 3; ++c) {
      EffectFit moved = fit;
      moved.calibration.centers_mm[k](c) += kStepMm;
      const std::vector<double> e2 = internal::ResidualsAt(data.table, &others, options, moved, data.points.source);
      for (std::size_t q = 0; q < rows.size(); ++q) {
        j(static_cast<Eigen::Index>(q), c) = (e2[rows[q]] - e[rows[q]]) / kStepMm;
      }
    }
    const Eigen::Vector3d step = j.colPivHouseholderQr().solve(-r);
    if (!step.allFinite()) break;
    fit.calibration.centers_mm[k] += step;
    e = internal::ResidualsAt(data.table, &others, options, fit, data.points.source);
    if (step.norm() < 1e-9) break;
  }
  return e;
}

// Whether `rest`, the model of `fit` fitted without one of its setups, still determines the effects
// and the form: none of their standard uncertainties is more than 10 times that of `fit` (all the
// setups). A combination the other setups leave loose (a probe polynomial beside a form seen in
// two orientations only) would predict the setup left out from the noise, metres wrong; fewer
// setups alone widen them by sqrt(n / (n - 1)) or so. True when either is not analysed.
bool DeterminedWithout(const EffectFit& rest, const EffectFit& fit) {
  constexpr double kMaxWidening = 10.0;
  const ObservabilityReport& a = rest.calibration.analysis;
  const ObservabilityReport& b = fit.calibration.analysis;
  if (a.Empty() || b.Empty()) return true;
  const int first_rest = kNumScmsParams + 3 * static_cast<int>(rest.calibration.setup_ids.size());
  const int first_all = kNumScmsParams + 3 * static_cast<int>(fit.calibration.setup_ids.size());
  for (int j = 0; first_rest + j < rest.n_params && first_all + j < fit.n_params; ++j) {
    const double wide = a.std(first_rest + j), narrow = b.std(first_all + j);
    if (!(wide <= kMaxWidening * narrow)) return false;
  }
  return true;
}

// Each reading's error [mm] when its setup is predicted from the others (LeaveOneSetupOutRms());
// NaN for a reading not predicted; empty with fewer than two setups. `loose`, when given, receives
// the setups whose prediction came from fits that do not determine the model (DeterminedWithout()).
std::vector<double> LeaveOneSetupOutErrors(const Readings& data, const CalibrationOptions& options,
                                           const EffectFit& fit, std::set<int>* loose) {
  const PointsData& points = data.points;
  const std::vector<int>& ids = fit.calibration.setup_ids;
  if (ids.size() < 2) return {};
  const std::size_t m = points.samples.size();
  // The fits without a setup are analysed when `fit` is, to see whether the others determine its
  // effects and form (DeterminedWithout(); the seven errors alone need no such check).
  CalibrationOptions rest_options = options;
  rest_options.analyse = loose != nullptr && !fit.calibration.analysis.Empty() &&
                         fit.n_params > kNumScmsParams + 3 * static_cast<int>(fit.calibration.setup_ids.size());
  std::vector<double> errors(points.samples.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<bool> held(m), others(m);  // fitted without the setup, then predicted on it
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const auto rotation = points.header.mount_rotations.find(ids[k]);
    if (rotation != points.header.mount_rotations.end() && !rotation->second.known()) continue;
    for (std::size_t i = 0; i < m; ++i) {
      held[i] = points.samples[i].setup == ids[k];
      others[i] = !held[i];
    }
    // The fit without the setup has no centre for it; the prediction starts its centre where the
    // fit of all the setups put it.
    EffectFitStart start = EffectFitStart::From(fit);
    start.centers_mm.erase(start.centers_mm.begin() + static_cast<std::ptrdiff_t>(k));
    EffectFit rest;
    try {
      rest = internal::FitEffectsRows(points, data.table, &held, rest_options, fit.model, start);
    } catch (const Error&) {
      continue;  // the other setups cannot be fitted without it (too few readings): not predicted
    }
    if (loose != nullptr && !DeterminedWithout(rest, fit)) loose->insert(ids[k]);
    EffectFit predict = rest;
    predict.calibration.setup_ids = ids;
    predict.calibration.centers_mm = fit.calibration.centers_mm;
    for (std::size_t j = 0; j < rest.calibration.setup_ids.size(); ++j) {
      const auto at = std::find(ids.begin(), ids.end(), rest.calibration.setup_ids[j]);
      predict.calibration.centers_mm[static_cast<std::size_t>(at - ids.begin())] = rest.calibration.centers_mm[j];
    }
    const std::vector<double> e = WithOwnCentre(data, others, options, predict, k);
    for (std::size_t i = 0; i < m; ++i) {
      if (held[i]) errors[i] = e[i];
    }
  }
  return errors;
}

// `errors_mm` with the readings of `setups` NaN: what the transfer test judges by.
std::vector<double> WithoutSetups(std::vector<double> errors_mm, const std::set<int>& setups,
                                  const PointsData& points) {
  if (setups.empty()) return errors_mm;
  for (std::size_t i = 0; i < errors_mm.size(); ++i) {
    if (setups.count(points.samples[i].setup) != 0) errors_mm[i] = std::numeric_limits<double>::quiet_NaN();
  }
  return errors_mm;
}

// The rms [um] of the finite `errors_mm`; NaN when none is.
double RmsUmOf(const std::vector<double>& errors_mm) {
  double sum2 = 0.0;
  std::size_t n = 0;
  for (const double e : errors_mm) {
    if (!std::isfinite(e)) continue;
    sum2 += e * e;
    ++n;
  }
  return n == 0 ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(sum2 / static_cast<double>(n)) * kUmPerMm;
}

// Student's t of the mean of e_with^2 - e_without^2 over the readings both predict: how clearly
// the model with a candidate predicts the setups left out worse (> 0) or better (< 0) than the
// model without it. The readings of one setup are not independent (a misprediction is smooth over
// the setup), so a clearly worse prediction must also be worse in every setup predicted: 0 when
// one setup is predicted better. NaN when fewer than two readings are predicted by both.
double PairedTransferT(const std::vector<double>& with_mm, const std::vector<double>& without_mm,
                       const PointsData& points) {
  double sum = 0.0, sum2 = 0.0;
  std::size_t n = 0;
  std::map<int, double> by_setup;  // the sum of d over each setup's readings
  for (std::size_t i = 0; i < std::min(with_mm.size(), without_mm.size()); ++i) {
    if (!std::isfinite(with_mm[i]) || !std::isfinite(without_mm[i])) continue;
    const double d = (with_mm[i] * with_mm[i] - without_mm[i] * without_mm[i]) * kUmPerMm * kUmPerMm;
    sum += d;
    sum2 += d * d;
    by_setup[points.samples[i].setup] += d;
    ++n;
  }
  if (n < 2) return std::numeric_limits<double>::quiet_NaN();
  for (const auto& [setup, d] : by_setup) {
    if (d <= 0.0) return 0.0;
  }
  const double mean = sum / static_cast<double>(n);
  const double var = (sum2 - sum * mean) / static_cast<double>(n - 1);
  if (!(var > 0.0)) return mean > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
  return mean / std::sqrt(var / static_cast<double>(n));
}

}  // namespace

double LeaveOneSetupOutRms(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  return RmsUmOf(LeaveOneSetupOutErrors(Readings(points), options, fit));
}

double CrossValidatedRms(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                         const EffectFitStart& start, int folds, std::uint64_t seed) {
  return CrossValidated(Readings(points), options, model, start, folds, seed);
}

namespace {

// The candidates of one round, each added to the current fit and scored.
using Tried = std::vector<std::pair<CandidateScore, EffectFit>>;

// Each effect of `todo` added to `current`, fitted and scored. The candidates are independent:
// they are scored on up to trace_options.threads threads, each writing only its own slot, so the result
// does not depend on the number of threads.
Tried ScoreCandidates(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                      const std::vector<Effect>& todo, int round, const TraceOptions& trace_options) {
  Tried tried(todo.size());
  std::vector<std::exception_ptr> failures(todo.size());
  std::mutex progress_mutex;
  int scored = 0;
  auto score = [&](std::size_t i) {
    try {
      CandidateScore& c = tried[i].first;
      c.effect = todo[i];
      c.round = round;
      EffectFit fit = FitCandidate(data, options, current.fit,
                                   DefaultTerm(todo[i], trace_options.harmonics, trace_options.drift_order),
                                   trace_options, &c.note);
      if (fit.model.terms.size() == current.fit.model.terms.size()) {
        c.delta_bic = std::numeric_limits<double>::quiet_NaN();  // nothing of it left to fit
        c.rms_um = current.fit.calibration.rms_um;
        c.cv_rms_um = current.cv_rms_um;
      } else {
        c.term = fit.model.terms.back();
        c.delta_bic = fit.Bic() - current.fit.Bic() + SearchPenalty(c.term, trace_options);
        c.rms_um = fit.calibration.rms_um;
        c.determined = fit.calibration.converged && fit.calibration.analysis.AllDetermined();
        if (!c.determined) {
          c.note += std::string(c.note.empty() ? "" : "; ") + "with it, some parameters are not determined";
        }
        // The cross-validated RMS decides only between the candidates the BIC admits (Admissible()),
        // and costs `folds` fits: the others are not cross-validated.
        c.cv_rms_um = c.determined && c.delta_bic <= -trace_options.min_delta_bic
                          ? CrossValidated(data, options, fit.model, EffectFitStart::From(fit), trace_options.folds,
                                           trace_options.seed)
                          : std::numeric_limits<double>::quiet_NaN();
        // So does the transfer test, with two or more setups: `folds` more fits at most.
        if (c.cv_rms_um < current.cv_rms_um && std::isfinite(current.loso_rms_um)) {
          std::set<int> loose;
          const std::vector<double> errors = LeaveOneSetupOutErrors(data, options, fit, &loose);
          c.loso_rms_um = RmsUmOf(errors);
          c.loso_t = PairedTransferT(WithoutSetups(errors, loose, data.points), current.loso_errors_mm, data.points);
        }
      }
      tried[i].second = std::move(fit);
    } catch (...) {
      failures[i] = std::current_exception();
    }
    if (!trace_options.progress) return;
    const std::lock_guard<std::mutex> lock(progress_mutex);
    trace_options.progress(round, ++scored, static_cast<int>(todo.size()));
  };
  ParallelFor(todo.size(), trace_options.threads, [&] { return score; });
  for (const std::exception_ptr& f : failures) {
    if (f) std::rethrow_exception(f);
  }
  return tried;
}

// Whether `c`, with two or more setups, predicts the setups left out clearly worse than the model
// without it (CandidateScore::loso_t): what a form or another function of the sphere's direction
// fitted as a machine error does (it turns with the sphere, a machine error does not).
bool Untransferred(const CandidateScore& c, const TraceOptions& trace_options) {
  return c.loso_t > trace_options.min_t;
}

// Whether a candidate may be added to `current`: a term with something to fit, every parameter
// determined, a BIC lower by trace_options.min_delta_bic, a lower cross-validated RMS, and, with two or
// more setups, not Untransferred().
bool Admissible(const CandidateScore& c, const TracedFit& current, const TraceOptions& trace_options) {
  return !c.term.components.empty() && c.determined && c.delta_bic <= -trace_options.min_delta_bic &&
         c.cv_rms_um < current.cv_rms_um && !Untransferred(c, trace_options);
}

// The admissible candidate of `tried` with the lowest delta BIC among those `also` accepts; -1:
// none.
template <typename Also>
int BestAdmissible(const Tried& tried, const TracedFit& current, const TraceOptions& trace_options, Also also) {
  int best = -1;
  for (std::size_t i = 0; i < tried.size(); ++i) {
    const CandidateScore& c = tried[i].first;
    if (Admissible(c, current, trace_options) && !c.held && also(c) &&
        (best < 0 || c.delta_bic < tried[static_cast<std::size_t>(best)].first.delta_bic)) {
      best = static_cast<int>(i);
    }
  }
  return best;
}

// The competitor no effect of the library is: a pattern fixed on the sphere (its form error, or an
// effect outside the library), the spherical harmonics that the BIC keeps, scored as if added to
// the current fit (its note is written once the round is decided: SphereCompetitorNote()).
CandidateScore SphereCompetitor(const SpherePattern& sphere, const TracedFit& current, int round) {
  CandidateScore form;
  form.sphere_form = true;
  form.round = round;
  form.delta_bic = sphere.delta_bic;
  const double rms_um = current.fit.calibration.rms_um;
  form.rms_um = std::sqrt(std::max(0.0, rms_um * rms_um - sphere.explained_rms_um * sphere.explained_rms_um));
  form.cv_rms_um = std::numeric_limits<double>::quiet_NaN();
  return form;
}

std::string SphereCompetitorNote(const SpherePattern& sphere, bool form_better, bool form_wins) {
  std::string functions;
  for (const std::string& f : sphere.functions) functions += (functions.empty() ? "" : " ") + f;
  return "a pattern fixed on the sphere, spherical harmonics of the direction from the centre, linearised: " +
         (functions.empty() ? std::string("none lowers the BIC")
                            : functions + (form_wins     ? "; explains the residual as well as any effect of the "
                                                           "library or better, so none is added"
                                           : form_better ? "; explains as much as the best effect or more, which "
                                                           "its own variable shows, so both are reported"
                                                         : "; less than the best effect"));
}

// Why candidate c was not added, appended to its note. `best`: the candidate added, if any.
void NoteWhyNotAdded(CandidateScore& c, bool admissible, bool form_wins, const CandidateScore* best,
                     const TracedFit& current, const TraceOptions& trace_options) {
  if (c.added) return;
  std::string why;
  if (admissible && form_wins) {
    why = "qualifies, but a pattern fixed on the sphere explains as much or more";
  } else if (admissible && best != nullptr) {
    why = "qualifies; " + best->Id() + Format(" scored better (delta BIC %.1f)", best->delta_bic);
  } else if (!c.term.components.empty() && c.determined) {
    if (c.delta_bic > -trace_options.min_delta_bic) {
      why = "too small a gain (delta BIC above -" + Format("%g", trace_options.min_delta_bic) + ")";
    } else if (!(c.cv_rms_um < current.cv_rms_um)) {
      why = "no lower cross-validated RMS";
    } else {
      why = Format(
          "does not transfer between setups: each predicted from the others %.4f um rms with it, %.4f um "
          "without (paired t %.1f)",
          c.loso_rms_um, current.loso_rms_um, c.loso_t);
    }
  }
  if (!why.empty()) c.note += std::string(c.note.empty() ? "" : "; ") + why;
}

// Whether one more placement would tell apart the candidates last in `a` and `b` (fits of the
// model of `current` with each added), in words.
std::string CheckedSeparation(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                              const EffectFit& a, const EffectFit& b) {
  const internal::PairSeparation p = internal::CheckPairSeparation(
      data.points, options, current, a.model.terms.back(), a.values.back(), b.model.terms.back(), b.values.back());
  if (!p.placement.empty()) {
    return Format(
        "%s tells them apart (largest variance inflation of their terms fitted together %.3g now, %.3g "
        "with it)",
        p.placement.c_str(), p.vif_now, p.vif_with);
  }
  return Format(
      "none of these tells them apart: %s (largest variance inflation of their terms fitted together %.3g "
      "now, at best %.3g with one of them; at most %.3g would): one of the two measured on its own",
      p.tried.c_str(), p.vif_now, p.vif_with, internal::kSeparatedVif);
}

// Whether the design cannot tell candidate c (fitted in `c_fit`) from the chosen effect (in
// `chosen_fit`), though c scored clearly worse: c explains at least half as much (its delta BIC at
// least half the chosen one's) and, with both beside the current model, a component of the two
// has a variance inflation above internal::kSeparatedVif on the readings as measured. A BIC gap
// between two such terms comes from which components each kept, not from the data telling them
// apart. Where that decides whether anything is added (TraceOptions::hold_confounded), the
// inflation that each term causes the other's components is judged instead (PairInflationNow(),
// above kSeparatedPairInflation):
// a term whose components are poorly determined beside the model anyway must not hold back every
// effect it is compared with.
bool ConfoundedByDesign(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                        const CandidateScore& c, const EffectFit& c_fit, const CandidateScore& chosen,
                        const EffectFit& chosen_fit, const TraceOptions& trace_options) {
  if (!(c.delta_bic <= 0.5 * chosen.delta_bic) || c_fit.model.terms.size() != current.model.terms.size() + 1) {
    return false;
  }
  const EffectTerm& a = chosen_fit.model.terms.back();
  const EffectTerm& b = c_fit.model.terms.back();
  if (!trace_options.hold_confounded) {
    return internal::PairVifNow(data.table, options, current, a, chosen_fit.values.back(), b, c_fit.values.back()) >
           internal::kSeparatedVif;
  }
  return internal::PairInflationNow(data.table, options, current, a, chosen_fit.values.back(), b, c_fit.values.back()) >
         kSeparatedPairInflation;
}

// The ambiguities of the effect chosen in a round: the other admissible candidates that scored
// almost as well or that the design cannot tell from it, and the sphere's form where it explains
// the same change of the residual.
void ChosenAmbiguities(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                       const Tried& tried, std::size_t best, const SpherePattern& sphere, bool form_better,
                       bool form_separable, const TraceOptions& trace_options, CandidateScore& chosen,
                       std::vector<Ambiguity>* ambiguous) {
  for (std::size_t i = 0; i < tried.size(); ++i) {
    const CandidateScore& c = tried[i].first;
    if (i == best || !Admissible(c, current, trace_options)) continue;
    // A candidate held back in an earlier round (TraceOptions::hold_confounded) may score better than
    // the one chosen now: it is about equal only when the two are within ambiguity_bic either way.
    const double gap = c.delta_bic - chosen.delta_bic;
    const bool close = (c.held ? std::abs(gap) : gap) < trace_options.ambiguity_bic;
    if (close ||
        ConfoundedByDesign(data, options, current.fit, c, tried[i].second, chosen, tried[best].second, trace_options)) {
      Ambiguity a{InfoOf(chosen.effect).id,           InfoOf(c.effect).id, chosen.delta_bic, c.delta_bic, 0.0,
                  SeparateBy(chosen.effect, c.effect)};
      a.by_design = !close;
      a.checked = CheckedSeparation(data, options, current.fit, tried[best].second, tried[i].second);
      ambiguous->push_back(a);
    }
  }
  // What the effect explains: the change of the residual. When that is mostly a pattern fixed on
  // the sphere, the sphere's own form error explains it as well.
  const EffectFit& with = tried[best].second;
  std::vector<double> signal(data.points.samples.size());
  for (std::size_t i = 0; i < signal.size(); ++i) {
    signal[i] = current.fit.calibration.residuals_mm[i] - with.calibration.residuals_mm[i];
  }
  {
    const internal::StructureJacobian jacobian(data.table, options, current.fit, current.expected_r_mm);
    chosen.sphere_fraction =
        SpherePatternFraction(FactorResidualStructure(ResidualsOfTraced(data, current, jacobian), &signal));
  }
  const double cur_rms = current.fit.calibration.rms_um, with_rms = with.calibration.rms_um;
  const double chosen_rms = std::sqrt(std::max(0.0, cur_rms * cur_rms - with_rms * with_rms));
  if (form_better) {
    Ambiguity a{InfoOf(chosen.effect).id, "sphere_form",          chosen.delta_bic,
                sphere.delta_bic,         chosen.sphere_fraction, SeparateFromForm(chosen.effect)};
    a.chosen_rms_um = chosen_rms;
    a.other_rms_um = sphere.explained_rms_um;
    ambiguous->push_back(a);
  } else if (!form_separable && chosen.sphere_fraction >= trace_options.max_sphere_fraction) {
    Ambiguity a{InfoOf(chosen.effect).id,
                "sphere_form",
                chosen.delta_bic,
                std::numeric_limits<double>::quiet_NaN(),
                chosen.sphere_fraction,
                "a second setup with the sphere turned on its mount (a form error turns with the sphere, a machine "
                "error stays with the machine), or the sphere's form from its certificate"};
    a.chosen_rms_um = chosen_rms;
    ambiguous->push_back(a);
  }
}

// With a design that separates the form: whether candidate c still lowers the extended BIC by
// min_delta_bic with the form at the highest degree searched in the model, as the time and probe
// effects must beyond a pattern in one placement (ShownBeyondSphere()). A candidate whose signal a
// form of some degree explains as well turns with the sphere in this design: a probe polynomial,
// for one, when the eccentricity points the same way on the sphere's body in every setup. `full`
// is the current model with that form (fitted once per round); *delta_ebic gets the candidate's
// score beside it (NaN where it is not separable from that form).
bool ShownBeyondForm(const Readings& data, const CalibrationOptions& options, const CandidateScore& c,
                     const EffectFit& full, const TraceOptions& trace_options, double* delta_ebic) {
  // A fit that does not settle, the form's alone or with the candidate: not separable from it.
  *delta_ebic = std::numeric_limits<double>::quiet_NaN();
  if (!full.calibration.converged) return false;
  EffectModel model = full.model;
  model.terms.push_back(c.term);
  const EffectFit with =
      internal::FitEffectsRows(data.points, data.table, nullptr, options, model, EffectFitStart::From(full));
  if (!with.calibration.converged) return false;
  *delta_ebic = with.Bic() - full.Bic() + SearchPenalty(c.term, trace_options);
  if (!(*delta_ebic <= -trace_options.min_delta_bic)) return false;
  // Its components must stay separable from that form, as FitCandidate() asks (that one of them
  // is less significant among that many form terms is no sign of the form explaining it).
  const int offset = with.TermOffset(model.terms.size() - 1);
  const Eigen::VectorXd& vif = with.calibration.analysis.vif;
  for (int k = 0; k < c.term.size(); ++k) {
    const int col = offset + k;
    if (col >= vif.size() || !(vif(col) <= trace_options.max_vif)) {
      *delta_ebic = std::numeric_limits<double>::quiet_NaN();
      return false;
    }
  }
  return true;
}

// The current model with the form of degrees 2..limit (its start: the current fit's).
EffectFit FullForm(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   const FormSelection& sel) {
  EffectModel model = current.fit.model;
  model.form = FormModelOf(data.points, FormTermsOfDegrees(2, sel.degree_limit));
  return internal::FitEffectsRows(data.points, data.table, nullptr, options, model, EffectFitStart::From(current.fit));
}

// The measurement that separates a probe effect from a form that turns with the sphere.
constexpr const char* kSeparateFromTurningForm =
    "orientations of the sphere on its mount that point the eccentricity elsewhere on its body, or a second "
    "eccentricity (sph_montecarlo --plan-orientations proposes orientations)";

// With a design that separates the form: the best admissible candidate of `tried` that still
// qualifies beside the form of the highest degree searched (ShownBeyondForm()), or -1. Those that
// qualify only without it get a note, go into *not_beyond_form and are reported in r.ambiguous as
// two explanations with that form, once per candidate (a later round's sizes replace an earlier's).
int BestBesideForm(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   const TraceOptions& trace_options, Tried& tried, TraceResult& r, std::set<Effect>* not_beyond_form) {
  const EffectFit full = FullForm(data, options, current, r.form);
  std::map<Effect, double> beyond;  // the candidates tried: their extended BIC beside that form
  const int best = BestAdmissible(tried, current, trace_options, [&](const CandidateScore& c) {
    return ShownBeyondForm(data, options, c, full, trace_options, &beyond[c.effect]);
  });
  const double cur_rms = current.fit.calibration.rms_um, full_rms = full.calibration.rms_um;
  for (auto& [c, fit] : tried) {
    const auto b = beyond.find(c.effect);
    if (b == beyond.end() || b->second <= -trace_options.min_delta_bic) continue;
    not_beyond_form->insert(c.effect);
    c.note +=
        std::string(c.note.empty() ? "" : "; ") +
        (std::isnan(b->second)
             ? Format("qualifies, but is not separable from the sphere's form of degrees 2..%d", r.form.degree_limit)
             : Format("qualifies, but not beside the sphere's form of degrees 2..%d (delta BIC %.1f there)",
                      r.form.degree_limit, b->second));
    Ambiguity a{"sphere_form", c.Id(), std::numeric_limits<double>::quiet_NaN(),
                c.delta_bic,   0.0,    kSeparateFromTurningForm};
    a.chosen_rms_um = std::sqrt(std::max(0.0, cur_rms * cur_rms - full_rms * full_rms));
    a.other_rms_um = std::sqrt(std::max(0.0, cur_rms * cur_rms - c.rms_um * c.rms_um));
    a.form_turns_with_sphere = true;
    // Once per candidate: a later round's sizes replace an earlier round's.
    const auto same = std::find_if(r.ambiguous.begin(), r.ambiguous.end(), [&](const Ambiguity& x) {
      return x.form_turns_with_sphere && x.chosen == a.chosen && x.other == a.other;
    });
    if (same != r.ambiguous.end()) {
      *same = a;
    } else {
      r.ambiguous.push_back(a);
    }
  }
  return best;
}

// Whether two terms have the same components (in any order).
bool SameComponents(const EffectTerm& a, const EffectTerm& b) {
  const auto key = [](const EffectTerm& t) {
    std::vector<std::tuple<int, int, bool>> k;
    for (const EffectComponent& c : t.components) k.emplace_back(c.order, c.axis, c.sine);
    std::sort(k.begin(), k.end());
    return k;
  };
  return a.effect == b.effect && key(a) == key(b);
}

// The components of the effects already in the model chosen again beside the one just added (the
// last term). A term's components were chosen when it joined the model, against the residual of
// that model: a large effect not yet fitted can hide a component of it (a probe gain of 10 um hides
// the linear part of a drift fitted before it, and a Theta encoder's c1 then takes the drift's
// place). Each earlier term is fitted again from all of its components, beside every other term,
// with FitCandidate()'s rule, and taken when the extended BIC falls.
void RefreshComponents(const Readings& data, const CalibrationOptions& options, const TraceOptions& trace_options,
                       TracedFit& current) {
  for (std::size_t t = 0; t + 1 < current.fit.model.terms.size(); ++t) {
    const EffectTerm& term = current.fit.model.terms[t];
    const EffectTerm full = DefaultTerm(term.effect, trace_options.harmonics, trace_options.drift_order);
    if (SameComponents(term, full)) continue;
    EffectModel model = current.fit.model;
    model.terms.erase(model.terms.begin() + static_cast<std::ptrdiff_t>(t));
    EffectFitStart start = EffectFitStart::From(current.fit);
    start.values.erase(start.values.begin() + static_cast<std::ptrdiff_t>(t));
    const EffectFit without = internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
    if (!without.calibration.converged) continue;
    std::string note;
    EffectFit again = FitCandidate(data, options, without, full, trace_options, &note);
    if (again.model.terms.size() != current.fit.model.terms.size() || !again.calibration.converged) continue;
    const EffectTerm& chosen = again.model.terms.back();
    if (SameComponents(chosen, term)) continue;
    const double change =
        again.Bic() + SearchPenalty(chosen, trace_options) - current.fit.Bic() - SearchPenalty(term, trace_options);
    if (!(change < 0.0)) continue;
    // The term moves to the end of the model; the one just added stays last.
    EffectFit reordered = std::move(again);
    std::rotate(reordered.model.terms.end() - 2, reordered.model.terms.end() - 1, reordered.model.terms.end());
    std::rotate(reordered.values.end() - 2, reordered.values.end() - 1, reordered.values.end());
    reordered = internal::FitEffectsRows(data.points, data.table, nullptr, options, reordered.model,
                                         EffectFitStart::From(reordered));
    current = Analysed(std::move(reordered), data, options, trace_options);
    --t;  // the term now at index t is the next one to look at
  }
}

// Whether effect e was held back in this trace (TraceOptions::hold_confounded).
bool IsHeld(const TraceResult& r, Effect e) { return std::find(r.held.begin(), r.held.end(), e) != r.held.end(); }

// With TraceOptions::hold_confounded: whether the candidate `c` just chosen is confounded with
// another library effect (an ambiguity of r.ambiguous from `first_new` on names one). Then neither
// is added: both are held back from later rounds (a third effect chosen later is still judged
// against them, for they are scored every round), the ambiguities say so, and what else was noted
// of the chosen effect (its share that is a pattern on the sphere) is dropped with it.
bool HoldConfounded(std::size_t first_new, CandidateScore& c, TraceResult& r) {
  std::string partners;
  for (auto a = r.ambiguous.begin() + static_cast<std::ptrdiff_t>(first_new); a != r.ambiguous.end(); ++a) {
    Effect e{};
    if (!EffectFromId(a->other, &e)) continue;  // "sphere_form"
    partners += (partners.empty() ? "" : ", ") + a->other +
                (a->by_design ? " (confounded by this design)" : " (about as good a score)");
    a->neither_added = true;
    if (!IsHeld(r, e)) r.held.push_back(e);
  }
  if (partners.empty()) return false;
  r.ambiguous.erase(std::remove_if(r.ambiguous.begin() + static_cast<std::ptrdiff_t>(first_new), r.ambiguous.end(),
                                   [](const Ambiguity& a) { return !a.neither_added; }),
                    r.ambiguous.end());
  r.held.push_back(c.effect);
  c.added = false;
  c.held = true;
  c.sphere_fraction = 0.0;  // of an added effect only
  c.note += std::string(c.note.empty() ? "" : "; ") + "qualifies, but held back: it cannot be told from " + partners +
            ", and neither is added";
  return true;
}

// One forward round: every effect of `pool` not yet in the model scored against `current`; the
// best admissible one is added (true), or none is and the search ends (false). The round's scores
// and ambiguities go into `r`.
bool ForwardRound(const Readings& data, const CalibrationOptions& options, const std::vector<Effect>& pool, int round,
                  const TraceOptions& trace_options, TracedFit& current, TraceResult& r) {
  std::vector<Effect> todo;
  for (Effect e : pool) {
    if (current.fit.model.Find(e) < 0) todo.push_back(e);
  }
  Tried tried = ScoreCandidates(data, options, current, todo, round, trace_options);
  for (auto& [c, fit] : tried) c.held = IsHeld(r, c.effect);
  const auto any = [](const CandidateScore&) { return true; };
  int best = BestAdmissible(tried, current, trace_options, any);
  // With a design that separates the form, it is in the model and no competitor. When the
  // competitor explains the residual better than the best effect, or about as well, no effect is
  // added.
  const SpherePattern sphere = r.form.separable ? SpherePattern{} : BestSpherePattern(current.factor);
  CandidateScore form = SphereCompetitor(sphere, current, round);
  // Within ambiguity_bic of the best effect the pattern counts as better: two explanations about
  // equal, and a machine effect is the claim that must be shown.
  const bool form_better = sphere.delta_bic <= -trace_options.min_delta_bic &&
                           (best < 0 || sphere.delta_bic < tried[static_cast<std::size_t>(best)].first.delta_bic +
                                                               trace_options.ambiguity_bic);
  // A pattern on the sphere never blocks an effect that its own variable shows: the best such
  // candidate is added, and both explanations are reported.
  if (form_better && best >= 0) {
    const bool one_placement = OnePlacement(current.fit);
    best = BestAdmissible(tried, current, trace_options, [&](const CandidateScore& c) {
      return ShownBeyondSphere(c, current.factor, one_placement, trace_options);
    });
  }
  const bool form_wins = form_better && best < 0;
  form.note = SphereCompetitorNote(sphere, form_better, form_wins);
  std::set<Effect> not_beyond_form;  // admissible, but a form of a higher degree explains them as well
  if (r.form.separable && best >= 0 && r.form.degree_limit > r.form.degree_max) {
    best = BestBesideForm(data, options, current, trace_options, tried, r, &not_beyond_form);
  }
  const CandidateScore* chosen = nullptr;
  bool hold = false;  // the chosen one cannot be told from another effect, and neither is added
  if (best < 0 || form_wins) {
    // An effect of the time or the probe reading that its variable shows, but no more than a form
    // would, and the best effect of the machine: both explanations, neither added.
    const int best_machine = form_wins
                                 ? BestAdmissible(tried, current, trace_options,
                                                  [](const CandidateScore& c) { return InfoOf(c.effect).harmonic; })
                                 : -1;
    for (std::size_t i = 0; i < tried.size(); ++i) {
      const CandidateScore& c = tried[i].first;
      const bool shown = ShownByItsVariable(c.effect, current.structure, trace_options);
      if (!form_wins || !Admissible(c, current, trace_options) || !(shown || static_cast<int>(i) == best_machine))
        continue;
      const double cur_rms = current.fit.calibration.rms_um;
      Ambiguity a{"sphere_form", c.Id(), sphere.delta_bic, c.delta_bic, 0.0, SeparateFromForm(c.effect)};
      a.chosen_rms_um = sphere.explained_rms_um;
      a.other_rms_um = std::sqrt(std::max(0.0, cur_rms * cur_rms - c.rms_um * c.rms_um));
      r.ambiguous.push_back(a);
    }
  } else {
    CandidateScore& c = tried[static_cast<std::size_t>(best)].first;
    c.added = true;
    const std::size_t first_new = r.ambiguous.size();
    ChosenAmbiguities(data, options, current, tried, static_cast<std::size_t>(best), sphere, form_better,
                      r.form.separable, trace_options, c, &r.ambiguous);
    chosen = &c;
    if (trace_options.hold_confounded) hold = HoldConfounded(first_new, c, r);
    if (hold) {
      for (auto& [other, fit] : tried) other.held = IsHeld(r, other.effect);  // its partners too
      if (form_better) form.note += "; the effect it was compared with is held back";
    }
  }
  for (auto& [c, fit] : tried) {
    if (not_beyond_form.count(c.effect) == 0 && !c.held) {
      NoteWhyNotAdded(c, Admissible(c, current, trace_options), form_wins, chosen, current, trace_options);
    } else if (c.held && !(hold && &c == chosen)) {
      c.note += std::string(c.note.empty() ? "" : "; ") + "held back: confounded with another effect, neither added";
    }
    r.candidates.push_back(c);
  }
  if (!r.form.separable) r.candidates.push_back(form);
  if (hold) return true;  // the next round chooses among the others, still judged against those held
  if (chosen == nullptr) return false;
  r.added.push_back(chosen->effect);
  current = Analysed(std::move(tried[static_cast<std::size_t>(best)].second), data, options, trace_options);
  RefreshComponents(data, options, trace_options, current);
  return true;
}

// Backward: an effect that the final model no longer needs (the BIC without it is less than
// min_delta_bic higher) is removed, the least needed first, and the rest refitted.
void RemoveUnneeded(const Readings& data, const CalibrationOptions& options, const TraceOptions& trace_options,
                    TracedFit& current, TraceResult& r) {
  while (!current.fit.model.terms.empty()) {
    int weakest = -1;
    double least = std::numeric_limits<double>::infinity();
    EffectFit without_weakest;
    for (std::size_t t = 0; t < current.fit.model.terms.size(); ++t) {
      EffectModel model = current.fit.model;
      model.terms.erase(model.terms.begin() + static_cast<std::ptrdiff_t>(t));
      EffectFitStart start = EffectFitStart::From(current.fit);
      start.values.erase(start.values.begin() + static_cast<std::ptrdiff_t>(t));
      EffectFit w = internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
      const double cost = w.Bic() - current.fit.Bic() - SearchPenalty(current.fit.model.terms[t], trace_options);
      if (w.calibration.converged && cost < least) {
        least = cost;
        weakest = static_cast<int>(t);
        without_weakest = std::move(w);
      }
    }
    if (weakest < 0 || least >= trace_options.min_delta_bic) break;
    const Effect e = current.fit.model.terms[static_cast<std::size_t>(weakest)].effect;
    r.removed.emplace_back(e, least);
    r.added.erase(std::find(r.added.begin(), r.added.end(), e));
    current = Analysed(std::move(without_weakest), data, options, trace_options);
  }
}

// The number of distinct angles among `angles_deg` (to 1e-6 deg), taken modulo a full turn.
int DistinctAngles(std::vector<double> angles_deg) {
  constexpr double kSameDeg = 1e-6;
  for (double& a : angles_deg) {
    a = std::fmod(a, 360.0);
    if (a < 0.0) a += 360.0;
  }
  std::sort(angles_deg.begin(), angles_deg.end());
  int n = 0;
  for (std::size_t i = 0; i < angles_deg.size(); ++i) {
    if (i == 0 || angles_deg[i] - angles_deg[i - 1] > kSameDeg) ++n;
  }
  if (n > 1 && angles_deg.front() + 360.0 - angles_deg.back() <= kSameDeg) --n;  // 0 and 360 - tiny
  return n;
}

int ResolvedOrder(int distinct) { return std::clamp((distinct - 1) / 2, 0, kMaxEffectHarmonic); }

// The highest order searched on one axis when the options leave it to the data: 4, or one above
// the highest order of the residual's own harmonics of that axis that is significant (its p-value
// below `p` shared among the orders tested): an error of order k shows at k - 1 and k + 1 through
// the eccentricity. At most what the pattern resolves.
int SearchedOrder(const std::vector<double>& order_p, double p, int pattern) {
  constexpr int kShortest = 4;
  int highest = 0;
  for (std::size_t k = 0; k < order_p.size(); ++k) {
    if (order_p[k] < p / static_cast<double>(order_p.size())) highest = static_cast<int>(k) + 1;
  }
  return std::min(std::max(kShortest, highest + 1), pattern);
}

// The highest harmonic orders searched: those of `trace_options`, the ones it leaves to the data (0)
// chosen by SearchedOrder() from the seven-error fit's residual structure `before`.
HarmonicOrders SearchedOrders(const TraceOptions& trace_options, const PointsData& points,
                              const ResidualStructure& before) {
  HarmonicOrders orders = trace_options.harmonics;
  const HarmonicOrders pattern = PatternOrders(points);
  if (orders.theta <= 0)
    orders.theta = SearchedOrder(before.theta_harmonic_p, trace_options.structure_p, pattern.theta);
  if (orders.phi <= 0) orders.phi = SearchedOrder(before.phi_cos_p, trace_options.structure_p, pattern.phi);
  return orders;
}

}  // namespace

HarmonicOrders PatternOrders(const PointsData& points) {
  std::vector<double> theta_deg, phi_deg;
  theta_deg.reserve(points.samples.size());
  phi_deg.reserve(points.samples.size());
  for (const Sample& s : points.samples) {
    theta_deg.push_back(s.theta_deg);
    phi_deg.push_back(s.phi_deg);
  }
  return {ResolvedOrder(DistinctAngles(std::move(theta_deg))), ResolvedOrder(DistinctAngles(std::move(phi_deg)))};
}

namespace {

// What a trace and a fit of fixed effects start from: the readings the seven-error fit used and the
// probe's reference. The start fills in the result's fit of no effect (`before`) and the harmonic
// orders searched (SearchedOrders()), which it writes into `trace_options` too.
struct TraceStart {
  Readings data;
  EffectReference reference;

  TraceStart(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
             TraceOptions& trace_options, TraceResult* r)
      : data(WithoutOutliers(all, base)), reference(ReferenceOf(all, trace_options)) {
    if (trace_options.probe_range_mm) {
      CheckReadingsInProbeRange(all, *trace_options.probe_range_mm, "probe_range_mm");
    }
    const std::size_t setups = base.setup_ids.size();
    const int base_params = kNumScmsParams + 3 * static_cast<int>(setups);
    CheckFoldsCanFit(data.points, trace_options.folds, base_params,
                     "the 7 errors and 3 centre coordinates for each of " + std::to_string(setups) + " setup(s)",
                     base_params);
    r->before = Analysed(FitNone(data, base, reference, trace_options), data, options, trace_options);
    r->harmonics = SearchedOrders(trace_options, data.points, r->before.structure);
    trace_options.harmonics = r->harmonics;
  }
};

// How both end: the outliers of the seven-error fit judged again under the final model, and the
// structure it leaves unexplained.
void Finish(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
            const TraceOptions& trace_options, TraceResult* r) {
  RejudgeOutliers(all, options, base, trace_options, r->after);
  if (r->after.fit.model.Find(Effect::kProbeDrift) >= 0 && !all.samples.empty()) {
    const auto [lo, hi] = std::minmax_element(all.samples.begin(), all.samples.end(),
                                              [](const Sample& a, const Sample& b) { return a.t_s < b.t_s; });
    if (lo->t_s == hi->t_s) {
      r->after.fit.calibration.warnings.push_back(
          "why: every sample has the same time t_s (" + Format("%g", lo->t_s) +
          " s), so a drift with time is not determined: probe_drift needs the times the readings were taken at");
    }
  }
  r->unexplained = RemainingStructure(r->after.structure, trace_options);
}

}  // namespace

TraceResult TraceResidual(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
                          TraceOptions trace_options) {
  TraceResult r;
  const TraceStart start(all, options, base, trace_options, &r);
  const Readings& data = start.data;
  std::vector<Effect> pool = trace_options.candidates;
  if (pool.empty()) {
    for (int e = 0; e < kNumEffects; ++e) pool.push_back(static_cast<Effect>(e));
  }
  TracedFit current = r.before;
  // The sphere's form first, where the design separates it from the machine.
  r.form = FormDesign(data.points, trace_options);
  if (r.form.separable) ConfoundedFormTerms(data, options, r.before.fit, pool, trace_options, &r.form);
  if (r.form.separable) {
    EffectFit with_form = SelectFormDegree(data, options, r.before.fit, trace_options, &r.form);
    if (!with_form.model.form.Empty()) current = Analysed(std::move(with_form), data, options, trace_options);
  }
  for (int round = 1; round <= trace_options.max_effects; ++round) {
    if (!ForwardRound(data, options, pool, round, trace_options, current, r)) break;
  }
  // The effects chosen, the form's degree is chosen again with them in the model.
  if (r.form.separable && !r.added.empty()) {
    EffectFit refit = SelectFormDegree(data, options, current.fit, trace_options, &r.form);
    if (refit.model.form.terms.size() != current.fit.model.form.terms.size()) {
      current = Analysed(std::move(refit), data, options, trace_options);
    }
  }
  RemoveUnneeded(data, options, trace_options, current, r);
  r.after = std::move(current);
  Finish(all, options, base, trace_options, &r);
  return r;
}

TraceResult FitFixedEffects(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
                            const std::vector<Effect>& effects, TraceOptions trace_options) {
  TraceResult r;
  const TraceStart start(all, options, base, trace_options, &r);
  EffectModel model;
  model.reference = start.reference;
  model.phi_wobble_pivot_mm = trace_options.phi_wobble_pivot_mm;
  for (Effect e : effects) {
    if (model.Find(e) < 0) model.terms.push_back(DefaultTerm(e, trace_options.harmonics, trace_options.drift_order));
  }
  int n_params = r.before.fit.n_params;
  std::string ids;
  for (const EffectTerm& t : model.terms) {
    r.added.push_back(t.effect);
    n_params += t.size();
    ids += (ids.empty() ? "" : ", ") + std::string(t.info().id);
  }
  CheckFoldsCanFit(start.data.points, trace_options.folds, n_params, "the seven-error model and " + ids,
                   r.before.fit.n_params);
  r.after = Analysed(internal::FitEffectsRows(start.data.points, start.data.table, nullptr, options, model,
                                              EffectFitStart::From(r.before.fit)),
                     start.data, options, trace_options);
  Finish(all, options, base, trace_options, &r);
  return r;
}

}  // namespace sph
