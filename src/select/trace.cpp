// The residual trace (sph/select/trace.hpp): what it starts from (the readings the seven-error fit
// kept, the probe's reference, the harmonic orders searched), its steps in order (trace_steps.hpp)
// and how it ends (the outliers judged again under the final model, the structure left).
#include "trace_steps.hpp"

namespace sph::internal {
namespace {

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
}  // namespace sph::internal

namespace sph {

using internal::DistinctAngles;
using internal::ResolvedOrder;

int FormDegreeLimit(const PointsData& points, const TraceOptions& trace_options) {
  return internal::FormDesign(points, trace_options).degree_limit;
}

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
}  // namespace sph

namespace sph::internal {
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

// The terms of every known form (options.form_prior's and other_form_priors'), by degree and order.
std::vector<FormTerm> KnownFormTerms(const CalibrationOptions& options) {
  std::vector<FormTerm> all = options.form_prior.terms;
  for (const auto& [setup, prior] : options.other_form_priors)
    all.insert(all.end(), prior.terms.begin(), prior.terms.end());
  int l_max = 0;
  for (const FormTerm& t : all) l_max = std::max(l_max, t.l);
  std::vector<FormTerm> terms;
  for (const FormTerm& t : FormTermsOfDegrees(2, l_max)) {
    if (std::find(all.begin(), all.end(), t) != all.end()) terms.push_back(t);
  }
  return terms;
}

// The model of `base` with the known forms (KnownFormTerms(); setups of unknown orientation and
// another sphere without a known form with forms of their own), fitted from the priors' means.
EffectFit WithKnownForm(const Readings& data, const CalibrationOptions& options, const EffectFit& base) {
  EffectModel model = base.model;
  model.form = FormModelOf(data.points, KnownFormTerms(options));
  EffectFitStart start = EffectFitStart::From(base);
  start.form_values.assign(static_cast<std::size_t>(model.form.NumGroups()),
                           std::vector<double>(model.form.terms.size(), 0.0));
  const auto set_start = [&](const FormPrior& prior, int group) {
    for (std::size_t i = 0; i < prior.terms.size(); ++i) {
      const auto it = std::find(model.form.terms.begin(), model.form.terms.end(), prior.terms[i]);
      start.form_values[static_cast<std::size_t>(group)][static_cast<std::size_t>(it - model.form.terms.begin())] =
          prior.mean_mm(static_cast<Eigen::Index>(i));
    }
  };
  set_start(options.form_prior, 0);
  for (const auto& [setup, prior] : options.other_form_priors) {
    if (model.form.setups.count(setup) > 0) set_start(prior, model.form.SetupOf(setup).group);
  }
  return internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
}

// `base`'s model with the effects `stated` (TraceResult::stated): each effect's default term
// with the components a fixed value or a prior names, fitted from `base`.
EffectFit WithStatedEffects(const Readings& data, const CalibrationOptions& options, const EffectFit& base,
                            const std::vector<Effect>& stated, const TraceOptions& trace_options) {
  EffectModel model = base.model;
  for (const Effect e : stated) {
    EffectTerm term = DefaultTerm(e, trace_options.harmonics, trace_options.drift_order);
    std::vector<std::string> names;
    for (const FixedParameter& f : options.fixed) names.push_back(f.name);
    for (const ParameterPrior& p : options.priors) names.push_back(p.name);
    for (const std::string& name : names) {
      EffectComponent c;
      if (name.rfind(std::string(InfoOf(e).id) + ".", 0) != 0 || !FindComponent(e, name, &c)) continue;
      const bool has = std::any_of(term.components.begin(), term.components.end(), [&](const EffectComponent& k) {
        return k.order == c.order && k.axis == c.axis && k.sine == c.sine;
      });
      if (!has) term.components.push_back(c);
    }
    model.terms.push_back(term);
  }
  EffectFitStart start = EffectFitStart::From(base);
  start.values.resize(model.terms.size());
  return internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
}

// The form selection of a trace whose form is known (FormSelection::known).
void KnownFormSelection(const CalibrationOptions& options, FormSelection* sel) {
  int l_max = 0;
  for (const FormTerm& t : KnownFormTerms(options)) l_max = std::max(l_max, t.l);
  sel->known = true;
  sel->separable = true;
  sel->degree_max = l_max;
  sel->degree_limit = l_max;
  sel->confounded.clear();
  sel->delta_ebic.clear();
  sel->design = "the sphere's form known, degrees 2.." + std::to_string(l_max) +
                ", in the model as a prior on its coefficients (it moves only within its covariance); every effect "
                "is judged beside it";
}

// How both end: the outliers of the seven-error fit judged again under the final model, the
// structure it leaves unexplained and its effects' error curves.
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
  r->curves = ErrorCurvesOf(all, options, r->after.fit, r->harmonics, trace_options.max_vif);
}
}  // namespace
}  // namespace sph::internal

namespace sph {

using internal::Analysed;
using internal::CheckFoldsCanFit;
using internal::ConfoundedFormTerms;
using internal::Finish;
using internal::FormDesign;
using internal::ForwardRound;
using internal::HigherDegrees;
using internal::KnownFormSelection;
using internal::Readings;
using internal::RemoveUnneeded;
using internal::SelectFormDegree;
using internal::TraceStart;
using internal::WithKnownForm;
using internal::WithStatedEffects;

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
  // The sphere's form first: known, or where the design separates it from the machine.
  r.form = FormDesign(data.points, trace_options);
  if (!options.form_prior.Empty()) {
    KnownFormSelection(options, &r.form);
    current = Analysed(WithKnownForm(data, options, r.before.fit), data, options, trace_options);
  } else if (r.form.separable) {
    ConfoundedFormTerms(data, options, r.before.fit, pool, trace_options, &r.form);
    EffectFit with_form = SelectFormDegree(data, options, r.before.fit, trace_options, &r.form);
    if (!with_form.model.form.Empty()) current = Analysed(std::move(with_form), data, options, trace_options);
  }
  // The effects a fixed value or a prior states, in the model from the start.
  r.stated = StatedEffects(options);
  if (!r.stated.empty()) {
    current =
        Analysed(WithStatedEffects(data, options, current.fit, r.stated, trace_options), data, options, trace_options);
    r.added = r.stated;
  }
  // A round that adds a set of k effects counts k among max_effects; one that holds back counts one.
  for (int round = 1, left = trace_options.max_effects; left > 0; ++round) {
    const std::size_t before = r.added.size();
    if (!ForwardRound(data, options, pool, round, left, trace_options, current, r)) break;
    left -= std::max(1, static_cast<int>(r.added.size() - before));
  }
  // The effects chosen, the form's degree is chosen again with them in the model.
  if (r.form.separable && !r.form.known && !r.added.empty()) {
    EffectFit refit = SelectFormDegree(data, options, current.fit, trace_options, &r.form);
    if (refit.model.form.terms.size() != current.fit.model.form.terms.size()) {
      current = Analysed(std::move(refit), data, options, trace_options);
    }
  }
  RemoveUnneeded(data, options, trace_options, current, r);
  if (r.form.separable) HigherDegrees(data, options, current, &r.form);
  r.after = std::move(current);
  Finish(all, options, base, trace_options, &r);
  return r;
}

std::vector<Effect> StatedEffects(const CalibrationOptions& options) {
  std::vector<std::string> names;
  for (const FixedParameter& f : options.fixed) names.push_back(f.name);
  for (const ParameterPrior& p : options.priors) names.push_back(p.name);
  std::vector<Effect> stated;
  for (const std::string& name : names) {
    const auto dot = name.find('.');
    Effect e{};
    if (dot == std::string::npos || !EffectFromId(name.substr(0, dot), &e)) continue;
    if (std::find(stated.begin(), stated.end(), e) == stated.end()) stated.push_back(e);
  }
  return stated;
}

namespace {
// A fit of a fixed model: the terms made by `terms_of` from the harmonic orders the start resolved
// (trace_options.harmonics), the form of `form_terms` (none when empty; options.form_prior's known
// form in its place), the probe terms normalised by `probe_reference` when given.
TraceResult FitModel(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
                     const std::function<std::vector<EffectTerm>(const TraceOptions&)>& terms_of,
                     const std::vector<FormTerm>& form_terms, TraceOptions trace_options,
                     const EffectReference* probe_reference) {
  TraceResult r;
  const TraceStart start(all, options, base, trace_options, &r);
  const std::vector<EffectTerm> terms = terms_of(trace_options);
  EffectModel model;
  model.reference = start.reference;
  if (probe_reference != nullptr) {
    model.reference.r_ref_mm = probe_reference->r_ref_mm;
    model.reference.r_half_range_mm = probe_reference->r_half_range_mm;
  }
  model.phi_wobble_pivot_mm = trace_options.phi_wobble_pivot_mm;
  int n_params = r.before.fit.n_params;
  std::string ids;
  for (const EffectTerm& t : terms) {
    model.terms.push_back(t);
    r.added.push_back(t.effect);
    n_params += t.size();
    ids += (ids.empty() ? "" : ", ") + std::string(t.info().id);
  }
  if (options.form_prior.Empty() && !form_terms.empty()) {
    model.form = FormModelOf(start.data.points, form_terms);
    n_params += model.form.NumParams();
    ids += (ids.empty() ? "" : ", ") + std::string("the sphere's form");
  }
  CheckFoldsCanFit(start.data.points, trace_options.folds, n_params, "the seven-error model and " + ids,
                   r.before.fit.n_params);
  EffectFit none = r.before.fit;
  if (!options.form_prior.Empty()) {
    KnownFormSelection(options, &r.form);
    none = WithKnownForm(start.data, options, r.before.fit);
    model.form = none.model.form;
  } else if (!model.form.Empty()) {
    r.form.separable = true;
    r.form.degree_max = r.form.degree_limit = model.form.MaxDegree();
    r.form.design = "the sphere's form of degrees 2.." + std::to_string(model.form.MaxDegree()) + " given, fitted";
  }
  r.after = Analysed(internal::FitEffectsRows(start.data.points, start.data.table, nullptr, options, model,
                                              EffectFitStart::From(none)),
                     start.data, options, trace_options);
  Finish(all, options, base, trace_options, &r);
  return r;
}
}  // namespace

TraceResult FitFixedEffects(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
                            const std::vector<Effect>& effects, TraceOptions trace_options) {
  const auto terms_of = [&](const TraceOptions& resolved) {
    std::vector<EffectTerm> terms;
    for (Effect e : effects) {
      const bool again = std::any_of(terms.begin(), terms.end(), [&](const EffectTerm& t) { return t.effect == e; });
      if (!again) terms.push_back(DefaultTerm(e, resolved.harmonics, resolved.drift_order));
    }
    return terms;
  };
  return FitModel(all, options, base, terms_of, {}, std::move(trace_options), nullptr);
}

TraceResult FitGivenModel(const PointsData& all, const CalibrationOptions& options, const CalibrationResult& base,
                          const std::vector<EffectTerm>& terms, const std::vector<FormTerm>& form_terms,
                          TraceOptions trace_options, const EffectReference* probe_reference) {
  return FitModel(all, options, base, [&](const TraceOptions&) { return terms; }, form_terms,
                  std::move(trace_options), probe_reference);
}
}  // namespace sph
