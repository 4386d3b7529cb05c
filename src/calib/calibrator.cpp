// The seven-error calibration: start values, the solve, outliers, analysis.
#include "sph/calib/calibrator.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <map>
#include <memory>
#include <set>

#include "calibrate_rows.hpp"
#include "fit_problem.hpp"
#include "problem_eval.hpp"
#include "solve_fit.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"
#include "sph/sphere/sphere_fit.hpp"

namespace sph {
namespace {

using internal::Format;

// Distinct values of an angle column, to 1e-6 deg.
std::size_t CountDistinct(const std::vector<double>& values) {
  std::set<long long> keys;
  for (double v : values) keys.insert(std::llround(v * 1e6));
  return keys.size();
}

// Explains in words why the undetermined parameters are undetermined.
void ExplainUndetermined(const PointsData& points, const std::vector<bool>* left_out, const CalibrationOptions& options,
                         CalibrationResult& result) {
  const ObservabilityReport& rep = result.analysis;
  const std::string names = rep.UndeterminedText();
  if (names.empty()) return;
  result.warnings.push_back(
      "undetermined parameters: " + names + "; a parameter counts as determined when its " +
      "standard uncertainty, as a displacement of the probed point (angles times R0), is at most " +
      Format("%g", options.max_std_um) + " um (--max-std-um)");

  // Offset of each centre from the Theta axis (what turns with theta) and along it.
  std::string offsets;
  for (std::size_t k = 0; k < result.centers_mm.size(); ++k) {
    const Eigen::Vector3d& c = result.centers_mm[k];
    offsets += std::string(offsets.empty() ? "" : "; ") +
               (result.centers_mm.size() > 1 ? "setup " + std::to_string(result.setup_ids[k]) + ": " : "") +
               Format("%.3g", std::hypot(c.x(), c.y())) + " mm off the Theta axis and " + Format("%.3g", c.z()) +
               " mm along it";
  }
  bool axis_related = false;
  for (std::size_t i = 0; i < rep.parameters.size() && i < kNumScmsParams; ++i) {
    if (!rep.determined[i]) axis_related = true;
  }
  if (axis_related) {
    result.warnings.push_back(
        "why: b, c, beta and epsilon move the probed point sideways, along the sphere's surface, and the measured "
        "distance sees such a shift only where the surface is tilted against the probe line, i.e. through the "
        "sphere's eccentricity; a centre on the Theta axis moreover looks the same from every theta. The centre is " +
        offsets +
        ". Place the sphere off the Theta axis (the paper's study uses 2 mm) or add a setup at another "
        "position.");
  }
  for (int id : result.setup_ids) {
    std::vector<double> thetas, phis;
    for (std::size_t i = 0; i < points.samples.size(); ++i) {
      const Sample& s = points.samples[i];
      if (s.setup != id || (left_out != nullptr && (*left_out)[i])) continue;
      thetas.push_back(s.theta_deg);
      phis.push_back(s.phi_deg);
    }
    const std::size_t nt = CountDistinct(thetas), np = CountDistinct(phis);
    const std::string where = result.setup_ids.size() > 1 ? " in setup " + std::to_string(id) : "";
    if (np < 3) {
      result.warnings.push_back("why: only " + std::to_string(np) + " phi position(s)" + where +
                                "; errors that act along the Phi swing (alpha, a, d' and the centre's height) need "
                                "points on at least three phi rings, spread over the sphere.");
    }
    if (nt < 3) {
      result.warnings.push_back("why: only " + std::to_string(nt) + " theta position(s)" + where +
                                "; the sphere must be turned through several Theta positions to separate the centre "
                                "from the axis errors.");
    }
  }
}

}  // namespace

Eigen::MatrixXd ResidualJacobian(const PointsData& points, const CalibrationOptions& options,
                                 const ScmsGeometry& geometry, const std::vector<Eigen::Vector3d>& centers_mm) {
  const internal::ReadingTable table(points);
  if (centers_mm.size() != table.setup_ids.size()) throw Error(points.source + ": one centre per setup is needed");
  const internal::SphereFitProblem problem(table, internal::AllRows(table), EffectModel{}, options);
  const Eigen::VectorXd x = problem.Pack(geometry, centers_mm, {});
  return problem.DenseJacobian(x.data());
}

bool CalibrationResult::Usable() const { return converged && (analysis.Empty() || analysis.AllDetermined()); }

namespace internal {

StartPoints::StartPoints(const ReadingTable& table, const CalibrationOptions& options)
    : table_(table),
      g_(options.initial_geometry),
      trig_(ErrorTrigOf(options.initial_geometry.data())),
      probe_offset_mm_(options.probe_offset_mm) {}

Eigen::Vector3d StartPoints::operator()(std::size_t i) const {
  return ScmsPoint(g_.data(), trig_, SinCos<double>{table_.sin_theta[i], table_.cos_theta[i]},
                   SinCos<double>{table_.sin_phi[i], table_.cos_phi[i]}, table_.r_mm[i], probe_offset_mm_);
}

std::vector<Sphere> StartSpheres(const ReadingTable& table, const CalibrationOptions& options,
                                 const std::vector<bool>* left_out) {
  // The fit reads each point twice (for the centroid, then for the sphere): a setup of up to
  // kBuffered rows has them computed once into a buffer, a larger one computes them twice rather
  // than hold them (24 bytes a row). The same points either way.
  constexpr std::size_t kBuffered = 1 << 16;
  const StartPoints point(table, options);
  std::vector<Sphere> spheres;
  std::vector<Eigen::Vector3d> buffer;
  for (const std::vector<std::uint32_t>& rows : AllRows(table, left_out)) {
    const auto n = static_cast<Eigen::Index>(rows.size());
    if (rows.size() > kBuffered) {
      spheres.push_back(
          FitSphereAlgebraic(n, [&](Eigen::Index i) { return point(rows[static_cast<std::size_t>(i)]); }));
      continue;
    }
    buffer.clear();
    buffer.reserve(rows.size());
    for (std::uint32_t row : rows) buffer.push_back(point(row));
    spheres.push_back(FitSphereAlgebraic(n, [&](Eigen::Index i) { return buffer[static_cast<std::size_t>(i)]; }));
  }
  return spheres;
}

CalibrationResult CalibrateRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                                const CalibrationOptions& options, const std::vector<Sphere>* start_spheres) {
  CheckFitOptions(points, options);
  RowsOfSetup rows = AllRows(table, left_out);
  CalibrationResult result;
  const std::size_t n_samples = SetupsWithRows(table, rows, &result.setup_ids);
  const std::size_t n_setups = result.setup_ids.size();
  CheckEnoughSamples(points.source, n_samples, kNumScmsParams + 3 * n_setups,
                     "7 errors and 3 centre coordinates for each of " + std::to_string(n_setups) + " setup(s)");

  // Initial values: the errors as given (zero by default), each centre from an algebraic sphere
  // fit of its setup's points computed with those errors (given when the caller has them).
  result.geometry = options.initial_geometry;
  const std::vector<Sphere> spheres = start_spheres ? *start_spheres : StartSpheres(table, options, left_out);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (rows[k].empty()) continue;
    const Sphere& fit = spheres[k];
    if (!fit.ok) {
      throw Error(points.source + ": the points of setup " +
                  std::to_string(result.setup_ids[result.centers_mm.size()]) +
                  " do not determine a sphere (fewer than four, or all on one plane or line)");
    }
    result.centers_mm.push_back(fit.center);
  }

  // One residual per sample (sph/ceres/sphere_residual.hpp), the gradient derived by hand
  // (sph/model/residual_gradient.hpp), solved by Ceres (solve_fit.hpp).
  const SphereFitProblem problem(table, std::move(rows), EffectModel{}, options);
  Eigen::VectorXd x = problem.Pack(result.geometry, result.centers_mm, {});
  const SolvedFit solved = SolveFit(problem, x, options, n_samples, result, points.source);
  problem.Unpack(x, &result.geometry, &result.centers_mm, nullptr);
  if (!options.analyse) return result;

  // Residuals in file order; the Jacobian's triangular factor at the solution, parameters in report order.
  std::vector<double> all(table.size(), 0.0);
  problem.Residuals(x.data(), all.data());
  result.residuals_mm.reserve(n_samples);
  double rss = 0.0;
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (left_out != nullptr && (*left_out)[i]) continue;
    result.residuals_mm.push_back(all[i]);
    rss += all[i] * all[i];
  }
  SetResidualStatistics(result);
  NoteWeightedReadings(points, solved, all, result);
  std::vector<ParameterDescription> desc = BaseParameterDescriptions(result.setup_ids, options.sphere_radius_mm);
  result.analysis = AnalyseSolved(problem, x, solved, solved.Plain() ? rss : WeightedRss(problem, solved, all),
                                  std::move(desc), options.max_std_um);
  ExplainUndetermined(points, left_out, options, result);
  return result;
}

}  // namespace internal

namespace {

double Median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Residual [mm] of every sample of the table under the result's parameters.
std::vector<double> ResidualsOf(const internal::ReadingTable& table, const CalibrationOptions& options,
                                const CalibrationResult& r) {
  internal::RowsOfSetup rows = internal::AllRows(table);
  std::vector<Eigen::Vector3d> centers;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (rows[k].empty()) continue;
    const auto it = std::find(r.setup_ids.begin(), r.setup_ids.end(), table.setup_ids[k]);
    if (it == r.setup_ids.end()) {
      rows[k].clear();  // a setup the fit did not see: no residuals (every reading an outlier)
      continue;
    }
    centers.push_back(r.centers_mm[static_cast<std::size_t>(it - r.setup_ids.begin())]);
  }
  const internal::SphereFitProblem problem(table, std::move(rows), EffectModel{}, options);
  std::vector<double> out(table.size(), 0.0);
  problem.Residuals(problem.Pack(r.geometry, centers, {}).data(), out.data());
  return out;
}

}  // namespace

namespace {

// "sample 18 (line 24, theta 240 deg, phi 7.5 deg, residual +999 um<more>)" for each of `count`
// readings (sample(k), residual_um(k), more(k)), cut after about 400 characters.
template <typename SampleOf, typename Residual, typename More>
std::string DescribeSamples(const PointsData& points, std::size_t count, SampleOf sample, Residual residual_um,
                            More more) {
  std::string rows;
  for (std::size_t k = 0; k < count; ++k) {
    if (rows.size() >= 400) return rows + "; ...";
    const std::size_t i = sample(k);
    const Sample& s = points.samples[i];
    const std::string line =
        i < points.sample_lines.size() ? "line " + std::to_string(points.sample_lines[i]) + ", " : "";
    rows += std::string(rows.empty() ? "" : "; ") + "sample " + std::to_string(i + 1) + " (" + line + "theta " +
            Format("%g", s.theta_deg) + " deg, phi " + Format("%g", s.phi_deg) + " deg, residual " +
            Format("%+.3g", residual_um(k)) + " um" + more(k) + ")";
  }
  return rows;
}

}  // namespace

std::string DescribeOutliers(const PointsData& points, const std::vector<Outlier>& outliers) {
  return DescribeSamples(
      points, outliers.size(), [&](std::size_t k) { return outliers[k].sample; },
      [&](std::size_t k) { return outliers[k].residual_um; }, [](std::size_t) { return std::string(); });
}

std::string DescribeWeightedReadings(const PointsData& points, const std::vector<WeightedReading>& readings) {
  return DescribeSamples(
      points, readings.size(), [&](std::size_t k) { return readings[k].sample; },
      [&](std::size_t k) { return readings[k].residual_um; },
      [&](std::size_t k) { return ", weight " + Format("%.3g", readings[k].weight); });
}

PointsData WithoutOutliers(const PointsData& points, const CalibrationResult& result) {
  PointsData kept = points;
  kept.samples.clear();
  kept.sample_lines.clear();
  std::size_t next = 0;
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    if (next < result.outliers.size() && result.outliers[next].sample == i) {
      ++next;
      continue;
    }
    kept.samples.push_back(points.samples[i]);
    if (i < points.sample_lines.size()) kept.sample_lines.push_back(points.sample_lines[i]);
  }
  return kept;
}

namespace {

// Marks the samples not yet out whose residual is farther than k robust standard deviations
// (1.4826 MAD, at least 1 nm, so that rounding-level residuals of exact data are no outliers)
// from the median of those not out, each setup by its own median and MAD. Returns whether any was
// marked. Why by setup: a gross error is a reading on its own; a whole setup off by a level or
// with a larger pattern (another sphere, its radius off by a probe's gain, a temperature) shows a
// model error, which the fit and the trace of its residual must see rather than lose as outliers.
bool MarkOutliers(const std::vector<double>& residuals, const std::vector<int>& setup, double k,
                  std::vector<bool>& out) {
  struct Level {
    double median = 0.0, limit = 0.0;
  };
  std::map<int, std::vector<double>> kept;  // by setup
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!out[i]) kept[setup[i]].push_back(residuals[i]);
  }
  std::map<int, Level> level;
  for (auto& [id, e] : kept) {
    Level& l = level[id];
    l.median = Median(e);
    for (double& x : e) x = std::abs(x - l.median);
    l.limit = std::max(k * 1.4826 * Median(e), 1e-6);
  }
  bool changed = false;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (out[i]) continue;
    const Level& l = level[setup[i]];
    if (!(std::abs(residuals[i] - l.median) <= l.limit)) out[i] = changed = true;
  }
  return changed;
}

// Residuals [mm] at the start of the fit: the initial errors, and per setup an algebraic sphere
// fit of the points not out. Gross errors stand out here, before least squares can spread them
// over the seven errors.
std::vector<double> StartResiduals(const internal::ReadingTable& table, const CalibrationOptions& options,
                                   const std::vector<bool>& out, std::vector<Sphere>* spheres_out) {
  const internal::StartPoints point(table, options);
  std::vector<Sphere>& spheres = *spheres_out;
  spheres = internal::StartSpheres(table, options, &out);
  std::vector<double> e(table.size(), 0.0);
  for (std::size_t i = 0; i < table.size(); ++i) {
    const Sphere& sphere = spheres[static_cast<std::size_t>(table.setup[i])];
    if (sphere.ok) e[i] = (point(i) - sphere.center).norm() - sphere.radius;
  }
  return e;
}

}  // namespace

std::vector<bool> RobustOutliers(const std::vector<double>& residuals_mm, const std::vector<int>& setup, double k) {
  std::vector<bool> out(residuals_mm.size(), false);
  if (k > 0.0) MarkOutliers(residuals_mm, setup, k, out);
  return out;
}

namespace internal {

CalibrationResult CalibrateTable(const PointsData& points, const ReadingTable& table,
                                 const CalibrationOptions& options) {
  if (!options.analyse || !options.LeavesOutOutliers()) return CalibrateRows(points, table, nullptr, options);
  // Robust rejection: the median and the median absolute deviation of the residuals do not follow
  // a few gross errors, as a least-squares fit does. Marked first at the start values, so that the
  // first fit is not pulled away by them; then judged again under each fit.
  std::vector<bool> out(table.size(), false);
  std::vector<Sphere> spheres;  // the start spheres of the readings not out, when `out` is still theirs
  bool spheres_of_out = false;
  for (int round = 0; round < 5 && !spheres_of_out; ++round) {
    spheres_of_out =
        !MarkOutliers(StartResiduals(table, options, out, &spheres), table.setup, options.outlier_sigma, out);
  }
  auto fit_kept = [&] {
    CalibrationResult r = CalibrateRows(points, table, &out, options, spheres_of_out ? &spheres : nullptr);
    spheres_of_out = false;
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (out[i]) r.outliers.push_back({i, 0.0});
    }
    return r;
  };
  CalibrationResult result = fit_kept();
  // Under the fit of the readings kept, the outliers are judged afresh (a reading marked at the
  // start may come back), until the set no longer changes.
  std::vector<double> residuals;
  for (int round = 0; round < 10; ++round) {
    residuals = ResidualsOf(table, options, result);
    const std::vector<bool> judged = RobustOutliers(residuals, table.setup, options.outlier_sigma);
    if (judged == out) break;
    out = judged;
    result = fit_kept();
    residuals.clear();
  }
  if (result.outliers.empty()) return result;
  result.residuals_mm = residuals.empty() ? ResidualsOf(table, options, result) : residuals;  // every sample
  for (Outlier& o : result.outliers) o.residual_um = result.residuals_mm[o.sample] * kUmPerMm;
  result.warnings.insert(
      result.warnings.begin(),
      std::to_string(result.outliers.size()) + " outlier(s) left out of the fit, farther than " +
          Format("%g", options.outlier_sigma) +
          " robust standard deviations from the median residual: " + DescribeOutliers(points, result.outliers));
  return result;
}

}  // namespace internal

CalibrationResult Calibrate(const PointsData& points, const CalibrationOptions& options) {
  return internal::CalibrateTable(points, internal::ReadingTable(points), options);
}

}  // namespace sph

namespace sph {

FormPrior CertificateFormPrior(double rms_mm, int l_max) {
  if (!(rms_mm > 0.0) || !std::isfinite(rms_mm) || l_max < 2) {
    throw Error("the certificate's form bound needs an RMS > 0 and degrees 2 to at least 2");
  }
  FormPrior prior;
  prior.terms = FormTermsOfDegrees(2, l_max);
  const auto k = static_cast<Eigen::Index>(prior.terms.size());
  prior.mean_mm = Eigen::VectorXd::Zero(k);
  const double variance = rms_mm * rms_mm / static_cast<double>(l_max - 1);
  prior.covariance_mm2 = variance * Eigen::MatrixXd::Identity(k, k);
  return prior;
}

}  // namespace sph
