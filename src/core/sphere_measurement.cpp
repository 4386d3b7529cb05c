#include "sph/core/sphere_measurement.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

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
  // rounding, so L comes from the eigen decomposition with negative eigenvalues set to zero.
  const Eigen::SelfAdjointEigenSolver<ScmsCovariance> eig(*cal.covariance);
  const ScmsCovariance l = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);

  std::vector<double> radius, pv_ls, pv_mz, form;
  std::vector<Eigen::Vector3d> center;
  std::vector<Eigen::Vector3d> points(readings.size());
  std::vector<double> change(readings.size());
  Calibration draw = cal;
  for (int s = 0; s < options.samples; ++s) {
    Eigen::Matrix<double, kNumScmsParams, 1> z;
    for (int k = 0; k < kNumScmsParams; ++k) z(k) = normal(rng);
    const Eigen::Matrix<double, kNumScmsParams, 1> dg = l * z;
    for (int k = 0; k < kNumScmsParams; ++k) {
      draw.geometry[static_cast<std::size_t>(k)] = cal.geometry[static_cast<std::size_t>(k)] + dg(k);
    }
    Compensate(draw, readings.data(), readings.size(), points.data());
    const LeastSquaresSphere ls = FitSphereLeastSquares(points);
    if (!ls.sphere.ok) continue;  // a draw that destroys the sphere says nothing about this one
    const std::vector<double> e = RadialResiduals(points, ls.sphere.center, ls.sphere.radius);
    for (std::size_t i = 0; i < e.size(); ++i) change[i] = e[i] - nominal.residuals_mm[i];
    radius.push_back(ls.sphere.radius);
    center.push_back(ls.sphere.center);
    pv_ls.push_back(PeakToValley(e));
    pv_mz.push_back(FitSphereMinimumZone(points, ls.sphere.center).width);
    form.push_back(PeakToValley(change));
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
