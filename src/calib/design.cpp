#include "sph/calib/design.hpp"

#include <cmath>
#include <limits>

#include "sph/calib/calibrator.hpp"
#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

// de/dx of the residual |p(theta, phi, r) - c| - R0 by central differences (the residual is smooth
// and of order 20 mm: steps of 1e-6 rad and 1e-6 mm give ~1e-10 relative error).
struct ReadingSlopes {
  double d_r, d_theta, d_phi;  // per mm, per rad, per rad
};

ReadingSlopes Slopes(const ScmsGeometry& g, const Sample& s, double d_mm, const Eigen::Vector3d& c, double radius_mm) {
  auto e = [&](double theta_rad, double phi_rad, double r_mm) {
    return (ScmsPoint(g, theta_rad, phi_rad, r_mm, d_mm) - c).norm() - radius_mm;
  };
  const double t = s.theta_rad(), p = s.phi_rad(), r = s.r_mm;
  const double h = 1e-6;
  return {(e(t, p, r + h) - e(t, p, r - h)) / (2 * h), (e(t + h, p, r) - e(t - h, p, r)) / (2 * h),
          (e(t, p + h, r) - e(t, p - h, r)) / (2 * h)};
}

}  // namespace

double PredictedUncertainty::StdAsDisplacementUm(int i) const {
  const ParameterDescription& p = parameters[static_cast<std::size_t>(i)];
  return std(i) * (p.quantity == Quantity::kAngle ? p.lever_mm : 1.0) * kUmPerMm;
}

double PredictedUncertainty::WorstErrorStdUm(int* which) const {
  double worst = 0.0;
  for (int i = 0; i < kNumScmsParams; ++i) {
    const double v = StdAsDisplacementUm(i);
    if (!(v <= worst)) {  // also takes NaN and inf
      worst = v;
      if (which != nullptr) *which = i;
    }
  }
  return worst;
}

PredictedUncertainty PredictUncertainty(const SimulationSpec& spec) {
  const PointsData exact = SimulateExact(spec);
  CalibrationOptions o;
  o.sphere_radius_mm = spec.sphere_radius_mm;
  o.probe_offset_mm = spec.probe_offset_mm;
  Eigen::MatrixXd jac = ResidualJacobian(exact, o, spec.truth, spec.centers_mm);
  const double sr = spec.noise_r_um * kMmPerUm;
  const double st = spec.noise_theta_arcsec * kRadPerArcsec;
  const double sp = spec.noise_phi_arcsec * kRadPerArcsec;
  Eigen::VectorXd jac_weight(jac.rows());  // 1 / s_i
  for (std::size_t i = 0; i < exact.samples.size(); ++i) {
    const Sample& s = exact.samples[i];
    const ReadingSlopes k = Slopes(spec.truth, s, spec.probe_offset_mm,
                                   spec.centers_mm[static_cast<std::size_t>(s.setup)], spec.sphere_radius_mm);
    const double var = sr * sr * k.d_r * k.d_r + st * st * k.d_theta * k.d_theta + sp * sp * k.d_phi * k.d_phi;
    if (!(var > 0.0)) throw Error("design: the noise is zero, so every parameter would be known exactly");
    jac_weight(static_cast<Eigen::Index>(i)) = 1.0 / std::sqrt(var);
    jac.row(static_cast<Eigen::Index>(i)) *= jac_weight(static_cast<Eigen::Index>(i));
  }

  PredictedUncertainty out;
  for (const auto& info : kScmsParamInfo) out.parameters.push_back({info.name, info.quantity, spec.sphere_radius_mm});
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    const std::string suffix = spec.centers_mm.size() > 1 ? "@" + std::to_string(k) : "";
    for (const char* axis : {"center_x", "center_y", "center_z"})
      out.parameters.push_back({axis + suffix, Quantity::kLength, 1.0});
  }
  // Covariance through the SVD of the column-equilibrated Jacobian (observability.hpp).
  const NormalInverse inv = InvertNormalMatrix(jac);
  const Eigen::Index n = jac.cols();
  out.condition_number = inv.condition_number;
  out.std = Eigen::VectorXd(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    out.std(j) = inv.in_null[static_cast<std::size_t>(j)] ? std::numeric_limits<double>::infinity()
                                                          : std::sqrt(inv.inverse(j, j));
  }
  if (!out.std.allFinite()) {
    out.bias = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
    return out;
  }

  // Box's second-order bias. C = (J^T W J)^-1; H_i by central differences of the (exact,
  // hand-derived) Jacobian: column k of H_i = (J_i(x + h e_k) - J_i(x - h e_k)) / 2h.
  const Eigen::MatrixXd& cov = inv.inverse;
  const Eigen::Index m = jac.rows();
  Eigen::VectorXd d = Eigen::VectorXd::Zero(m);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double h =
        k < kNumScmsParams && kScmsParamInfo[static_cast<std::size_t>(k)].quantity == Quantity::kAngle ? 1e-6 : 1e-5;
    auto shifted = [&](double step) {
      ScmsGeometry g = spec.truth;
      std::vector<Eigen::Vector3d> c = spec.centers_mm;
      if (k < kNumScmsParams) {
        g[static_cast<std::size_t>(k)] += step;
      } else {
        c[static_cast<std::size_t>((k - kNumScmsParams) / 3)]((k - kNumScmsParams) % 3) += step;
      }
      return ResidualJacobian(exact, o, g, c);
    };
    const Eigen::MatrixXd dj = (shifted(h) - shifted(-h)) / (2 * h);  // row i: column k of H_i
    d += dj * cov.col(k);                                             // sum_j H_i(j, k) C(j, k)
  }
  // jac is already weighted by W^(1/2); d_i must be too.
  for (Eigen::Index i = 0; i < m; ++i) d(i) *= jac_weight(i);
  out.bias = -0.5 * cov * (jac.transpose() * d);
  return out;
}

std::optional<double> SmallestEccentricityMm(SimulationSpec spec, const std::vector<Eigen::Vector3d>& directions,
                                             double target_um, double lo_mm, double hi_mm) {
  auto worst_at = [&](double e_mm) {
    spec.centers_mm.clear();
    for (const auto& d : directions) spec.centers_mm.push_back(e_mm * d.normalized());
    return PredictUncertainty(spec).WorstErrorStdUm();
  };
  if (worst_at(hi_mm) > target_um) return std::nullopt;
  if (worst_at(lo_mm) <= target_um) return lo_mm;
  // The std of the tangential errors falls monotonically with e (as 1/e^2): bisect on log e.
  double lo = std::log(lo_mm), hi = std::log(hi_mm);
  for (int it = 0; it < 60 && hi - lo > 1e-6; ++it) {
    const double mid = 0.5 * (lo + hi);
    (worst_at(std::exp(mid)) <= target_um ? hi : lo) = mid;
  }
  return std::exp(hi);
}

}  // namespace sph
