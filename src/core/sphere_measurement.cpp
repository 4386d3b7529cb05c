#include "sph/core/sphere_measurement.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <mutex>
#include <random>
#include <stdexcept>
#include <system_error>
#include <thread>

#include <Eigen/Eigenvalues>

#include "sph/core/error.hpp"

namespace sph {
namespace {

std::string Format(const char* fmt, double a, double b = 0.0, double c = 0.0, double d = 0.0) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

// Sample standard deviation, of the values shifted by the first one: a radius of 20 mm varying by
// nanometres keeps its digits, and equal values give exactly 0.
double StdOf(const std::vector<double>& v) {
  double mean = 0.0;
  for (const double x : v) mean += x - v.front();
  mean /= static_cast<double>(v.size());
  double ss = 0.0;
  for (const double x : v) ss += (x - v.front() - mean) * (x - v.front() - mean);
  return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

}  // namespace

SphereEvaluation EvaluateSphere(const std::vector<Eigen::Vector3d>& points_mm, const std::string& source,
                                const SphereEvaluationOptions& options) {
  SphereEvaluation ev;
  ev.n_points = static_cast<int>(points_mm.size());
  if (points_mm.size() < 4) {
    throw Error(source + ": " + std::to_string(points_mm.size()) +
                " points are too few to determine a sphere (at least 4)");
  }
  ev.ls = FitSphereLeastSquares(points_mm);
  if (!ev.ls.sphere.ok) {
    throw Error(source + ": the points determine no sphere (they lie on one plane or line, or coincide)");
  }
  ev.residuals_mm = RadialResiduals(points_mm, ev.ls.sphere.center, ev.ls.sphere.radius);
  ev.sphericity_ls_mm = PeakToValley(ev.residuals_mm);
  ev.mz = FitSphereMinimumZone(points_mm, ev.ls.sphere.center);
  ev.coverage = CoverageOf(points_mm, ev.ls.sphere.center);
  ev.radius_dilution = ev.ls.RadiusDilution();
  ev.center_dilution = ev.ls.CenterDilution();
  if (ev.n_points > 4) {
    const double s2 = ev.ls.rms * ev.ls.rms * ev.n_points / (ev.n_points - 4);
    ev.radius_fit_std_mm = std::sqrt(s2 * ev.ls.normal_inverse(3, 3));
    ev.center_fit_std_mm = (s2 * ev.ls.normal_inverse.diagonal().head<3>()).cwiseSqrt();
  }

  if (std::max(ev.radius_dilution, ev.center_dilution) > options.max_dilution) {
    ev.poorly_determined = true;
    ev.warnings.push_back(Format(
        "ill-posed for the coverage: seen from the centre, the points lie within %.0f deg of their mean direction, so "
        "they determine "
        "the radius %.3g times and the centre %.3g times worse than the same number of points over the whole sphere "
        "(limit %g); radius, centre and both sphericities are poorly determined: measure a larger part of the sphere",
        ev.coverage.cap_half_angle_deg, ev.radius_dilution, ev.center_dilution, options.max_dilution));
  }
  if (ev.n_points <= 5) {
    ev.warnings.push_back(Format(
        "only %.0f points: a sphere has 4 parameters and a minimum zone 5 contact points, so the sphericity says "
        "little about the form",
        ev.n_points));
  }
  if (!ev.ls.converged) ev.warnings.push_back("the least-squares fit did not converge");
  if (!ev.mz.ok || !ev.mz.converged) ev.warnings.push_back("the minimum-zone search did not converge");
  return ev;
}

CalibrationUncertainty PropagateCalibrationUncertainty(const std::vector<RawReading>& readings, const Calibration& cal,
                                                       const SphereEvaluation& nominal,
                                                       const UncertaintyOptions& options) {
  if (!cal.covariance) throw std::invalid_argument("the calibration has no covariance to propagate");
  if (options.samples < 2) throw std::invalid_argument("at least 2 samples are needed for a standard deviation");
  if (readings.size() != nominal.residuals_mm.size()) {
    throw std::invalid_argument("the readings are not those of the nominal evaluation");
  }
  CalibrationUncertainty u;
  u.samples = options.samples;
  u.seed = options.seed;

  // g_s = g + L z, z ~ N(0, I), L L^T = Sigma; a covariance from a fit can be semidefinite to
  // rounding, so L comes from the eigen decomposition with negative eigenvalues set to zero. The
  // draws come first, in order, so that the result depends on the seed only, not on the threads.
  const Eigen::SelfAdjointEigenSolver<ScmsCovariance> eig(*cal.covariance);
  const ScmsCovariance l = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<ScmsGeometry> draws(static_cast<std::size_t>(options.samples));
  for (ScmsGeometry& g : draws) {
    Eigen::Matrix<double, kNumScmsParams, 1> z;
    for (int k = 0; k < kNumScmsParams; ++k) z(k) = normal(rng);
    const Eigen::Matrix<double, kNumScmsParams, 1> dg = l * z;
    for (int k = 0; k < kNumScmsParams; ++k) {
      g[static_cast<std::size_t>(k)] = cal.geometry[static_cast<std::size_t>(k)] + dg(k);
    }
  }
  // The readings' sines and cosines, once for all draws.
  std::vector<EffectReading> fixed;
  fixed.reserve(readings.size());
  for (const RawReading& r : readings) fixed.emplace_back(r.theta_deg, r.phi_deg, r.r_mm, 0.0);

  struct Outcome {
    bool ok = false;
    double radius = 0.0, pv_ls = 0.0, pv_mz = 0.0, form = 0.0;
    Eigen::Vector3d center = Eigen::Vector3d::Zero();
  };
  std::vector<Outcome> outcomes(draws.size());
  std::atomic<std::size_t> next{0};
  std::size_t done = 0;
  std::mutex progress_mutex;
  std::exception_ptr failure;  // the first exception of a worker, rethrown here
  auto work = [&] {
    std::vector<Eigen::Vector3d> points(readings.size());
    Calibration draw = cal;
    SphereFitOptions ls_options;
    ls_options.start = nominal.ls.sphere;  // each draw's sphere is near the nominal one
    for (std::size_t s; (s = next++) < draws.size();) {
      draw.geometry = draws[s];
      const internal::CompensationContext ctx(draw);
      for (std::size_t i = 0; i < fixed.size(); ++i) points[i] = internal::CompensateWith(draw, ctx, fixed[i]);
      const LeastSquaresSphere ls = FitSphereLeastSquares(points, ls_options);
      Outcome& o = outcomes[s];
      if (ls.sphere.ok) {  // a draw that destroys the sphere says nothing about this one
        // Peak-to-valley of the residuals and of their change from the nominal evaluation.
        double lo = std::numeric_limits<double>::infinity(), hi = -lo, change_lo = lo, change_hi = -lo;
        for (std::size_t i = 0; i < points.size(); ++i) {
          const double e = (points[i] - ls.sphere.center).norm() - ls.sphere.radius;
          const double change = e - nominal.residuals_mm[i];
          lo = std::min(lo, e);
          hi = std::max(hi, e);
          change_lo = std::min(change_lo, change);
          change_hi = std::max(change_hi, change);
        }
        o = {true,
             ls.sphere.radius,
             hi - lo,
             FitSphereMinimumZone(points, ls.sphere.center).width,
             change_hi - change_lo,
             ls.sphere.center};
      }
      const std::lock_guard<std::mutex> lock(progress_mutex);  // counted and told in order
      ++done;
      if (options.progress) options.progress(static_cast<int>(done), options.samples);
    }
  };
  auto worker = [&] {
    try {
      work();
    } catch (...) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      if (!failure) failure = std::current_exception();
      next = draws.size();  // the others stop after their current draw
    }
  };
  unsigned n_threads =
      options.threads > 0 ? static_cast<unsigned>(options.threads) : std::thread::hardware_concurrency();
  n_threads = std::max(1u, std::min<unsigned>(n_threads, static_cast<unsigned>(draws.size())));
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < n_threads; ++w) {
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error&) {
      break;  // no more threads to be had: this one does the rest
    }
  }
  worker();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);

  std::vector<double> radius, pv_ls, pv_mz, form;
  std::vector<Eigen::Vector3d> center;
  for (const Outcome& o : outcomes) {
    if (!o.ok) continue;
    radius.push_back(o.radius);
    center.push_back(o.center);
    pv_ls.push_back(o.pv_ls);
    pv_mz.push_back(o.pv_mz);
    form.push_back(o.form);
  }
  if (radius.size() < 2) throw std::invalid_argument("no calibration draw gave a sphere");
  u.radius_std_mm = StdOf(radius);
  for (int k = 0; k < 3; ++k) {
    std::vector<double> ck;
    for (const auto& c : center) ck.push_back(c(k));
    u.center_std_mm(k) = StdOf(ck);
  }
  u.sphericity_ls_std_mm = StdOf(pv_ls);
  u.sphericity_mz_std_mm = StdOf(pv_mz);
  std::sort(form.begin(), form.end());
  const auto k95 = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(form.size()))) - 1;
  u.calibration_form_p95_mm = form[k95];
  u.form_exceeds_calibration = nominal.sphericity_ls_mm > u.calibration_form_p95_mm;
  return u;
}

}  // namespace sph
