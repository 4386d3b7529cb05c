#include "sph/calib/design.hpp"

#include <cmath>
#include <limits>

#include "block_factor.hpp"
#include "fit_problem.hpp"
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
  const double sr = spec.noise_r_um * kMmPerUm;
  const double st = spec.noise_theta_arcsec * kRadPerArcsec;
  const double sp = spec.noise_phi_arcsec * kRadPerArcsec;
  const auto m = static_cast<Eigen::Index>(exact.samples.size());
  Eigen::VectorXd weight(m);  // 1 / s_i
  for (Eigen::Index i = 0; i < m; ++i) {
    const Sample& s = exact.samples[static_cast<std::size_t>(i)];
    const ReadingSlopes k = Slopes(spec.truth, s, spec.probe_offset_mm,
                                   spec.centers_mm[static_cast<std::size_t>(s.setup)], spec.sphere_radius_mm);
    const double var = sr * sr * k.d_r * k.d_r + st * st * k.d_theta * k.d_theta + sp * sp * k.d_phi * k.d_phi;
    if (!(var > 0.0)) throw Error("design: the noise is zero, so every parameter would be known exactly");
    weight(i) = 1.0 / std::sqrt(var);
  }

  PredictedUncertainty out;
  for (const auto& info : kScmsParamInfo) out.parameters.push_back({info.name, info.quantity, spec.sphere_radius_mm});
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    const std::string suffix = spec.centers_mm.size() > 1 ? "@" + std::to_string(k) : "";
    for (const char* axis : {"center_x", "center_y", "center_z"})
      out.parameters.push_back({axis + suffix, Quantity::kLength, 1.0});
  }
  // Covariance through the SVD of the column-equilibrated weighted Jacobian (observability.hpp); with
  // many placements through its block structure (every reading depends on the seven errors and
  // its own centre), at a cost linear in their number.
  const internal::ReadingTable table(exact);
  const internal::SphereFitProblem problem(table, internal::AllRows(table), EffectModel{}, o);
  const Eigen::VectorXd x = problem.Pack(spec.truth, spec.centers_mm, {});
  const int setups = problem.NumSetups();
  NormalInverse inv;
  if (internal::AnalyseByBlocks(setups, kNumScmsParams)) {
    inv = problem.FactorBlocks(x.data(), nullptr, weight.data()).Invert();
  } else {
    Eigen::MatrixXd jac = problem.DenseJacobian(x.data());
    jac = weight.asDiagonal() * jac;
    inv = InvertNormalMatrix(jac);
  }
  const Eigen::Index n = problem.NumParams();
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

  // Box's second-order bias. C = (J^T W J)^-1, H_i = d^2 e_i / dx^2 by central differences of the
  // (exact, hand-derived) Jacobian. Reading i depends on the seven errors and its own centre only:
  // d_i = tr(C H_i) sums over those ten (local) parameters, H_i's columns from moving one of the
  // errors, or one coordinate of every centre at once (each reading sees its own move).
  constexpr int kLocal = kNumScmsParams + 3;
  const Eigen::MatrixXd& cov = inv.inverse;
  auto local_jacobian = [&](const Eigen::VectorXd& at) {
    Eigen::Matrix<double, Eigen::Dynamic, kLocal, Eigen::RowMajor> rows(m, kLocal);
    problem.ForEachBlock(at.data(), nullptr, true, [&](const internal::RowBlock& b) {
      for (int i = 0; i < b.count; ++i) {
        for (int c = 0; c < kLocal; ++c) rows(b.rows[i], c) = b.cols[c * internal::SphereFitProblem::kBlockRows + i];
      }
    });
    return rows;
  };
  auto global = [&](int local, int setup) -> Eigen::Index {
    return local < kNumScmsParams ? local : kNumScmsParams + 3 * setup + (local - kNumScmsParams);
  };
  Eigen::VectorXd d = Eigen::VectorXd::Zero(m);
  for (int k = 0; k < kLocal; ++k) {
    const double h =
        k < kNumScmsParams && kScmsParamInfo[static_cast<std::size_t>(k)].quantity == Quantity::kAngle ? 1e-6 : 1e-5;
    Eigen::VectorXd plus = x, minus = x;
    for (int s = 0; s < (k < kNumScmsParams ? 1 : setups); ++s) {
      plus(global(k, s)) += h;
      minus(global(k, s)) -= h;
    }
    const auto dj = ((local_jacobian(plus) - local_jacobian(minus)) / (2 * h)).eval();  // row i: column k of H_i
    for (Eigen::Index i = 0; i < m; ++i) {
      const int s = table.setup[static_cast<std::size_t>(i)];
      for (int j = 0; j < kLocal; ++j) d(i) += dj(i, j) * cov(global(j, s), global(k, s));
    }
  }
  // bias = -1/2 C J^T W d, with J^T W d summed reading by reading over their local parameters.
  const auto jac = local_jacobian(x);
  Eigen::VectorXd jtwd = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < m; ++i) {
    const int s = table.setup[static_cast<std::size_t>(i)];
    for (int j = 0; j < kLocal; ++j) jtwd(global(j, s)) += jac(i, j) * weight(i) * weight(i) * d(i);
  }
  out.bias = -0.5 * cov * jtwd;
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
