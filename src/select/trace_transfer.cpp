// The transfer test of the trace: cross-validation over folds of the readings, the prediction of
// each setup from the others (leave one setup out), and the paired t of two models' predictions.
#include "trace_steps.hpp"

namespace sph::internal {

double CrossValidated(const Readings& data, const CalibrationOptions& options, const EffectModel& model,
                      const EffectFitStart& start, int folds, std::uint64_t seed) {
  const std::size_t m = data.points.samples.size();
  // Folds within each setup, so that every fold leaves every setup points to fit its centre.
  std::map<int, std::vector<std::size_t>> of_setup;
  for (std::size_t i = 0; i < m; ++i) of_setup[data.points.samples[i].setup].push_back(i);
  Random rng(seed);
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

namespace {

// The readings of setup `k` of `fit` (rows not in `others`) under `fit` with that setup's centre
// refitted, and with it the components of the model's terms of the time (a drift): a drift
// fitted to the other setups' times says nothing of this one's, and carried over to it would be
// no test of whether the model transfers between setups. By Gauss-Newton with a forward-difference
// Jacobian (the model's own residuals, so every effect and the form are in it); their residuals
// [mm], table-indexed (the others 0).
std::vector<double> WithOwnCentreAndDrift(const Readings& data, const std::vector<bool>& others,
                                          const CalibrationOptions& options, EffectFit fit, std::size_t k) {
  constexpr double kStepMm = 1e-6;
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < others.size(); ++i) {
    if (!others[i]) rows.push_back(i);
  }
  // The parameters refitted: the centre's x, y, z, then each component of a term of the time.
  std::vector<std::pair<std::size_t, std::size_t>> timed;  // (term, component)
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    if (!Follows(fit.model.terms[t].effect, "t")) continue;
    for (std::size_t c = 0; c < fit.values[t].size(); ++c) timed.emplace_back(t, c);
  }
  const auto value = [&](EffectFit& f, Eigen::Index c) -> double& {
    if (c < 3) return f.calibration.centers_mm[k](c);
    const auto& [t, q] = timed[static_cast<std::size_t>(c - 3)];
    return f.values[t][q];
  };
  const Eigen::Index n = 3 + static_cast<Eigen::Index>(timed.size());
  std::vector<double> e = internal::ResidualsAt(data.table, &others, options, fit, data.points.source);
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::MatrixXd j(static_cast<Eigen::Index>(rows.size()), n);
    Eigen::VectorXd r(static_cast<Eigen::Index>(rows.size()));
    for (std::size_t q = 0; q < rows.size(); ++q) r(static_cast<Eigen::Index>(q)) = e[rows[q]];
    for (Eigen::Index c = 0; c < n; ++c) {
      EffectFit moved = fit;
      value(moved, c) += kStepMm;
      const std::vector<double> e2 = internal::ResidualsAt(data.table, &others, options, moved, data.points.source);
      for (std::size_t q = 0; q < rows.size(); ++q) {
        j(static_cast<Eigen::Index>(q), c) = (e2[rows[q]] - e[rows[q]]) / kStepMm;
      }
    }
    const Eigen::VectorXd step = j.colPivHouseholderQr().solve(-r);
    if (!step.allFinite()) break;
    for (Eigen::Index c = 0; c < n; ++c) value(fit, c) += step(c);
    e = internal::ResidualsAt(data.table, &others, options, fit, data.points.source);
    if (step.norm() < 1e-9) break;
  }
  return e;
}

// Whether `rest`, the model of `fit` fitted without one of its setups, still determines the effects
// and the form: none of their standard uncertainties is more than 10 times that of `fit` (all the
// setups). A combination the other setups leave loose (a probe polynomial beside a form seen in
// two orientations only) would predict the setup left out from the noise, metres wrong; fewer
// setups alone widen them by sqrt(n / (n - 1)) or so. A term of the time is not checked: it is
// refitted on the setup predicted (WithOwnCentreAndDrift()). True when either is not analysed.
bool DeterminedWithout(const EffectFit& rest, const EffectFit& fit) {
  constexpr double kMaxWidening = 10.0;
  const ObservabilityReport& a = rest.calibration.analysis;
  const ObservabilityReport& b = fit.calibration.analysis;
  if (a.Empty() || b.Empty()) return true;
  const int first_rest = kNumScmsParams + 3 * static_cast<int>(rest.calibration.setup_ids.size());
  const int first_all = kNumScmsParams + 3 * static_cast<int>(fit.calibration.setup_ids.size());
  std::vector<bool> timed;  // per parameter after the centres: of a term of the time
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    timed.insert(timed.end(), fit.values[t].size(), Follows(fit.model.terms[t].effect, "t"));
  }
  for (int j = 0; first_rest + j < rest.n_params && first_all + j < fit.n_params; ++j) {
    if (static_cast<std::size_t>(j) < timed.size() && timed[static_cast<std::size_t>(j)]) continue;
    const double wide = a.std(first_rest + j), narrow = b.std(first_all + j);
    if (!(wide <= kMaxWidening * narrow)) return false;
  }
  return true;
}
}  // namespace

std::vector<double> LeaveOneSetupOutErrors(const Readings& data, const CalibrationOptions& options,
                                           const EffectFit& fit, std::set<int>* not_judged) {
  const PointsData& points = data.points;
  const std::vector<int>& ids = fit.calibration.setup_ids;
  if (ids.size() < 2) return {};
  const std::size_t m = points.samples.size();
  // The fits without a setup are analysed when `fit` is, to see whether the others determine its
  // effects and form (DeterminedWithout(); the seven errors alone need no such check).
  CalibrationOptions rest_options = options;
  rest_options.analyse = !fit.calibration.analysis.Empty() &&
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
    if (!DeterminedWithout(rest, fit)) {
      if (not_judged != nullptr) not_judged->insert(ids[k]);
      continue;
    }
    EffectFit predict = rest;
    predict.calibration.setup_ids = ids;
    predict.calibration.centers_mm = fit.calibration.centers_mm;
    for (std::size_t j = 0; j < rest.calibration.setup_ids.size(); ++j) {
      const auto at = std::find(ids.begin(), ids.end(), rest.calibration.setup_ids[j]);
      predict.calibration.centers_mm[static_cast<std::size_t>(at - ids.begin())] = rest.calibration.centers_mm[j];
    }
    const std::vector<double> e = WithOwnCentreAndDrift(data, others, options, predict, k);
    for (std::size_t i = 0; i < m; ++i) {
      if (held[i]) errors[i] = e[i];
    }
  }
  return errors;
}

void TransferTest(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                  const EffectFit& fit, CandidateScore* c) {
  if (!(c->cv_rms_um < current.cv_rms_um) || !std::isfinite(current.loso_rms_um)) return;
  const std::vector<double> errors = LeaveOneSetupOutErrors(data, options, fit);
  c->loso_rms_um = RmsUmOf(errors);
  c->loso_t = PairedTransferT(errors, current.loso_errors_mm, data.points);
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
}  // namespace sph::internal

namespace sph {

using internal::CrossValidated;
using internal::LeaveOneSetupOutErrors;
using internal::Readings;
using internal::RmsUmOf;

double LeaveOneSetupOutRms(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  const Readings data(points);
  return RmsUmOf(LeaveOneSetupOutErrors(data, options, fit));
}

double CrossValidatedRms(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                         const EffectFitStart& start, int folds, std::uint64_t seed) {
  return CrossValidated(Readings(points), options, model, start, folds, seed);
}
}  // namespace sph
