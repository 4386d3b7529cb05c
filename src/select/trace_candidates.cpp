// The candidates of the trace: an effect's term added to the current model, the components the
// data cannot separate or do not show left out, fitted, analysed, and scored (BIC, cross-validation,
// prediction of the setups left out), each round's candidates in parallel.
#include "trace_steps.hpp"

namespace sph::internal {

// The extended BIC's charge for the components `term` keeps of those its effect's default term
// searched (FitCandidate() keeps only the separable and significant ones).
double SearchPenalty(const EffectTerm& term, const TraceOptions& trace_options) {
  const auto searched = DefaultTerm(term.effect, trace_options.harmonics, trace_options.drift_order).components.size();
  return SubsetSearchPenalty(static_cast<int>(searched), static_cast<int>(term.components.size()));
}

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

namespace {

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
}  // namespace

// What the residual analyses need of a traced fit.
FitResiduals ResidualsOfTraced(const Readings& data, const TracedFit& t, const JacobianBlocks& jacobian) {
  return {data.points, t.fit.calibration.residuals_mm, t.expected_r_mm, jacobian, t.fit.model.reference, t.directions};
}

TracedFit Factored(EffectFit fit, const Readings& data, const CalibrationOptions& options) {
  TracedFit t;
  t.expected_r_mm = ExpectedReadings(data.points, options, fit);
  t.directions = Directions(data.points, options, fit, t.expected_r_mm);
  t.fit = std::move(fit);
  const internal::StructureJacobian jacobian(data.table, options, t.fit, t.expected_r_mm);
  t.factor = FactorResidualStructure(ResidualsOfTraced(data, t, jacobian));
  return t;
}

TracedFit Analysed(EffectFit fit, const Readings& data, const CalibrationOptions& options,
                   const TraceOptions& trace_options) {
  TracedFit t = Factored(std::move(fit), data, options);
  t.structure = AnalyseResidualStructure(t.factor);
  // A harmonic of theta above what the pattern resolves aliases onto a lower one (or onto a
  // constant, or has no sine on the readings): fitted alone it has no amplitude of its own.
  const auto resolved = static_cast<std::size_t>(PatternOrders(data.points).theta);
  for (std::size_t k = resolved; k < t.structure.theta_harmonics_um.size(); ++k) {
    t.structure.theta_harmonics_um[k] = std::numeric_limits<double>::quiet_NaN();
  }
  t.cv_rms_um =
      CrossValidated(data, options, t.fit.model, EffectFitStart::From(t.fit), trace_options.folds, trace_options.seed);
  std::set<int> not_judged;
  t.loso_errors_mm = LeaveOneSetupOutErrors(data, options, t.fit, &not_judged);
  t.loso_rms_um = RmsUmOf(t.loso_errors_mm);
  t.loso_not_judged.assign(not_judged.begin(), not_judged.end());
  return t;
}

namespace {

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
}  // namespace

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
  // fit: the fit would only crawl along their valley. The problem has the priors' rows: a form known
  // within its covariance separates what a free form would not (a power of the probe reading, in
  // one placement a form of low degree).
  for (;;) {
    EffectFit at_start;
    at_start.model = model;
    at_start.values = start.values;
    at_start.form_values = start.form_values;
    at_start.calibration.geometry = start.geometry;
    at_start.calibration.centers_mm = start.centers_mm;
    at_start.calibration.setup_ids = current.calibration.setup_ids;
    at_start.calibration.prior_sigma_mm = current.calibration.prior_sigma_mm;  // the priors' weight
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
        // So does the transfer test.
        TransferTest(data, options, current, fit, &c);
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
}  // namespace sph::internal
