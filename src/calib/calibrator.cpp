// The only translation unit of the library that instantiates Ceres templates.
#include "sph/calib/calibrator.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cstddef>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>

#include "problem_eval.hpp"
#include "sph/ceres/sphere_residual_batch.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/sphere_fit.hpp"
#include "sph/model/units.hpp"

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
void ExplainUndetermined(const PointsData& points, const CalibrationOptions& options, CalibrationResult& result) {
  const ObservabilityReport& rep = result.analysis;
  std::string names;
  for (std::size_t i = 0; i < rep.parameters.size(); ++i) {
    if (rep.determined[i]) continue;
    const double disp = rep.StdAsDisplacementUm(static_cast<int>(i));
    names += (names.empty() ? "" : ", ") + rep.parameters[i].name +
             (std::isfinite(disp) ? " (std " + Format("%.3g", disp) + " um)" : " (no information at all)");
  }
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
    for (const Sample& s : points.samples) {
      if (s.setup != id) continue;
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
  const std::vector<int> ids = points.SetupIds();
  if (centers_mm.size() != ids.size()) throw Error(points.source + ": one centre per setup is needed");
  const Eigen::Index n = kNumScmsParams + 3 * static_cast<Eigen::Index>(ids.size());
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(points.samples.size()), n);
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < ids.size(); ++k) index[ids[k]] = k;
  using Jet = SphereResidualBatch::Jet;
  Jet g[kNumScmsParams];
  for (int k = 0; k < kNumScmsParams; ++k) g[k] = Jet(geometry[static_cast<std::size_t>(k)], k);
  const ScmsErrorTrig<Jet> trig = ErrorTrigOf(g);
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    const std::size_t k = index[s.setup];
    Jet c[3];
    for (int j = 0; j < 3; ++j) c[j] = Jet(centers_mm[k](j), kNumScmsParams + j);
    const SphereResidual functor(s.theta_deg * kRadPerDeg, s.phi_deg * kRadPerDeg, s.r_mm, options.probe_offset_mm,
                                 options.sphere_radius_mm);
    Jet e;
    functor.Evaluate(g, trig, c, &e);
    const auto row = static_cast<Eigen::Index>(i);
    jac.row(row).head<kNumScmsParams>() = e.v.head<kNumScmsParams>().transpose();
    jac.row(row).segment<3>(kNumScmsParams + 3 * static_cast<Eigen::Index>(k)) = e.v.tail<3>().transpose();
  }
  return jac;
}

bool CalibrationResult::Usable() const { return converged && (analysis.Empty() || analysis.AllDetermined()); }

namespace {

// One least-squares fit of all samples of `points`.
CalibrationResult CalibrateAll(const PointsData& points, const CalibrationOptions& options) {
  const std::string& src = points.source;
  if (!(options.sphere_radius_mm > 0.0)) throw Error(src + ": the sphere radius must be positive");
  if (!(options.probe_offset_mm > 0.0)) throw Error(src + ": the probe offset must be positive");

  CalibrationResult result;
  result.setup_ids = points.SetupIds();
  const std::size_t n_setups = result.setup_ids.size();
  const std::size_t n_params = kNumScmsParams + 3 * n_setups;
  if (points.samples.size() <= n_params) {
    throw Error(src + ": " + std::to_string(points.samples.size()) + " samples are too few to fit " +
                std::to_string(n_params) + " parameters (7 errors and 3 centre coordinates for each of " +
                std::to_string(n_setups) + " setup(s))");
  }
  std::map<int, std::size_t> setup_index;
  for (std::size_t k = 0; k < n_setups; ++k) setup_index[result.setup_ids[k]] = k;

  // Per sample: sin and cos of the readings (used for the start values and by the residuals).
  struct ReadingTrig {
    SinCos<double> theta, phi;
  };
  std::vector<ReadingTrig> trig;
  trig.reserve(points.samples.size());
  for (const Sample& s : points.samples)
    trig.push_back({SinCosOf(s.theta_deg * kRadPerDeg), SinCosOf(s.phi_deg * kRadPerDeg)});

  // Initial values: the errors as given (zero by default), each centre from an algebraic sphere
  // fit of its setup's points computed with those errors.
  result.geometry = options.initial_geometry;
  const ScmsErrorTrig<double> start_trig = ErrorTrigOf(result.geometry.data());
  std::vector<std::vector<Eigen::Vector3d>> nominal(n_setups);
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    nominal[setup_index[s.setup]].push_back(
        ScmsPoint(result.geometry.data(), start_trig, trig[i].theta, trig[i].phi, s.r_mm, options.probe_offset_mm));
  }
  std::vector<std::array<double, 3>> centers(n_setups);
  for (std::size_t k = 0; k < n_setups; ++k) {
    const Sphere fit = FitSphereAlgebraic(nominal[k]);
    if (!fit.ok) {
      throw Error(src + ": the points of setup " + std::to_string(result.setup_ids[k]) +
                  " do not determine a sphere (fewer than four, or all on one plane or line)");
    }
    centers[k] = {fit.center.x(), fit.center.y(), fit.center.z()};
  }

  // One residual per sample, grouped into one cost function per setup (sph/ceres/sphere_residual_batch.hpp).
  std::vector<std::vector<SphereResidual>> readings(n_setups);
  std::vector<std::vector<std::size_t>> rows_of_setup(n_setups);  // sample index of each residual
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    rows_of_setup[setup_index[s.setup]].push_back(i);
    readings[setup_index[s.setup]].emplace_back(trig[i].theta, trig[i].phi, s.r_mm, options.probe_offset_mm,
                                                options.sphere_radius_mm);
  }
  ceres::Problem problem;
  for (std::size_t k = 0; k < n_setups; ++k) {
    problem.AddResidualBlock(new SphereResidualBatch(std::move(readings[k])), nullptr, result.geometry.data(),
                             centers[k].data());
  }

  const ceres::Solver::Options solver_options = internal::CalibrationSolverOptions(options.max_iterations);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;  // iteration 0 is the start
  result.solver_message = summary.message;
  result.n_points = static_cast<int>(points.samples.size());
  for (const auto& c : centers) result.centers_mm.emplace_back(c[0], c[1], c[2]);
  if (!result.converged) {
    result.warnings.push_back("the solver did not converge: " + summary.message);
  }
  if (!options.analyse) return result;

  // Residuals and Jacobian at the solution, parameters in report order, rows in file order.
  std::vector<double*> blocks{result.geometry.data()};
  for (auto& c : centers) blocks.push_back(c.data());
  std::vector<std::size_t> sample_of_row;
  for (const auto& rows : rows_of_setup) sample_of_row.insert(sample_of_row.end(), rows.begin(), rows.end());
  Eigen::MatrixXd jac;
  internal::EvaluateInFileOrder(problem, blocks, sample_of_row, static_cast<Eigen::Index>(n_params),
                                &result.residuals_mm, &jac);
  internal::SetResidualStatistics(result);
  const Eigen::Map<const Eigen::VectorXd> res(result.residuals_mm.data(),
                                              static_cast<Eigen::Index>(result.residuals_mm.size()));

  std::vector<ParameterDescription> desc = internal::BaseParameterDescriptions(result.setup_ids, options.sphere_radius_mm);
  result.analysis = AnalyseFit(jac, res, std::move(desc), options.max_std_um);
  ExplainUndetermined(points, options, result);
  return result;
}

double Median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Residual [mm] of every sample of `points` under the result's parameters.
std::vector<double> ResidualsOf(const PointsData& points, const CalibrationOptions& options,
                                const CalibrationResult& r) {
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < r.setup_ids.size(); ++k) index[r.setup_ids[k]] = k;
  const ScmsErrorTrig<double> trig = ErrorTrigOf(r.geometry.data());
  std::vector<double> out;
  out.reserve(points.samples.size());
  for (const Sample& s : points.samples) {
    const Eigen::Vector3d p = ScmsPoint(r.geometry.data(), trig, SinCosOf(s.theta_deg * kRadPerDeg),
                                        SinCosOf(s.phi_deg * kRadPerDeg), s.r_mm, options.probe_offset_mm);
    out.push_back((p - r.centers_mm[index.at(s.setup)]).norm() - options.sphere_radius_mm);
  }
  return out;
}

}  // namespace

std::string DescribeOutliers(const PointsData& points, const std::vector<Outlier>& outliers) {
  std::string rows;
  for (const Outlier& o : outliers) {
    if (rows.size() >= 400) return rows + "; ...";
    const Sample& s = points.samples[o.sample];
    const std::string line =
        o.sample < points.sample_lines.size() ? "line " + std::to_string(points.sample_lines[o.sample]) + ", " : "";
    rows += std::string(rows.empty() ? "" : "; ") + "sample " + std::to_string(o.sample + 1) + " (" + line + "theta " +
            Format("%g", s.theta_deg) + " deg, phi " + Format("%g", s.phi_deg) + " deg, residual " +
            Format("%+.3g", o.residual_um) + " um)";
  }
  return rows;
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
// from the median of those not out. Returns whether any was marked.
bool MarkOutliers(const std::vector<double>& residuals, double k, std::vector<bool>& out) {
  std::vector<double> kept;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!out[i]) kept.push_back(residuals[i]);
  }
  if (kept.empty()) return false;
  const double med = Median(kept);
  for (double& e : kept) e = std::abs(e - med);
  const double limit = std::max(k * 1.4826 * Median(kept), 1e-6);
  bool changed = false;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!out[i] && !(std::abs(residuals[i] - med) <= limit)) out[i] = changed = true;
  }
  return changed;
}

// Residuals [mm] at the start of the fit: the initial errors, and per setup an algebraic sphere
// fit of the points not out. Gross errors stand out here, before least squares can spread them
// over the seven errors.
std::vector<double> StartResiduals(const PointsData& points, const CalibrationOptions& options,
                                   const std::vector<bool>& out) {
  const ScmsErrorTrig<double> trig = ErrorTrigOf(options.initial_geometry.data());
  std::vector<Eigen::Vector3d> p(points.samples.size());
  std::map<int, std::vector<Eigen::Vector3d>> kept;
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    p[i] = ScmsPoint(options.initial_geometry.data(), trig, SinCosOf(s.theta_deg * kRadPerDeg),
                     SinCosOf(s.phi_deg * kRadPerDeg), s.r_mm, options.probe_offset_mm);
    if (!out[i]) kept[s.setup].push_back(p[i]);
  }
  std::map<int, Sphere> spheres;
  for (const auto& [id, pts] : kept) spheres[id] = FitSphereAlgebraic(pts);
  std::vector<double> e(points.samples.size(), 0.0);
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const auto it = spheres.find(points.samples[i].setup);
    if (it != spheres.end() && it->second.ok) e[i] = (p[i] - it->second.center).norm() - it->second.radius;
  }
  return e;
}

}  // namespace

std::vector<bool> RobustOutliers(const std::vector<double>& residuals_mm, double k) {
  std::vector<bool> out(residuals_mm.size(), false);
  if (k > 0.0) MarkOutliers(residuals_mm, k, out);
  return out;
}

CalibrationResult Calibrate(const PointsData& points, const CalibrationOptions& options) {
  if (!options.analyse || !(options.outlier_sigma > 0.0)) return CalibrateAll(points, options);
  // Robust rejection: the median and the median absolute deviation of the residuals do not follow
  // a few gross errors, as a least-squares fit does. Marked first at the start values, so that the
  // first fit is not pulled away by them; then judged again under each fit.
  std::vector<bool> out(points.samples.size(), false);
  for (int round = 0; round < 5 && MarkOutliers(StartResiduals(points, options, out), options.outlier_sigma, out);
       ++round) {
  }
  auto fit_kept = [&] {
    CalibrationResult r;
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (out[i]) r.outliers.push_back({i, 0.0});
    }
    const std::vector<Outlier> outliers = r.outliers;
    r = CalibrateAll(WithoutOutliers(points, r), options);
    r.outliers = outliers;
    return r;
  };
  CalibrationResult result = fit_kept();
  // Under the fit of the readings kept, the outliers are judged afresh (a reading marked at the
  // start may come back), until the set no longer changes.
  for (int round = 0; round < 10; ++round) {
    const std::vector<bool> judged = RobustOutliers(ResidualsOf(points, options, result), options.outlier_sigma);
    if (judged == out) break;
    out = judged;
    result = fit_kept();
  }
  if (result.outliers.empty()) return result;
  result.residuals_mm = ResidualsOf(points, options, result);  // every sample, in file order
  for (Outlier& o : result.outliers) o.residual_um = result.residuals_mm[o.sample] * kUmPerMm;
  result.warnings.insert(result.warnings.begin(),
                         std::to_string(result.outliers.size()) + " outlier(s) left out of the fit, farther than " +
                             Format("%g", options.outlier_sigma) +
                             " robust standard deviations from the median residual: " +
                             DescribeOutliers(points, result.outliers));
  return result;
}

}  // namespace sph
