// Measurement design: what a pattern, a sphere placement and a noise level can determine, predicted
// without simulating.
//
// For readings with independent noise (sigma_r on r, sigma_theta and sigma_phi on the angles) the
// residual e_i of reading i has the variance
//   s_i^2 = sigma_r^2 (de_i/dr)^2 + sigma_theta^2 (de_i/dtheta)^2 + sigma_phi^2 (de_i/dphi)^2,
// and the covariance of the least-squares estimate, to first order (the Cramer-Rao bound for
// Gaussian noise), is
//   C = (J^T W J)^-1,  W = diag(1 / s_i^2),  J = de/d(errors, centres) at the truth.
// With noise on r alone and |de/dr| ~ 1 this is sigma_r^2 (J^T J)^-1.
#ifndef SPH_CALIB_DESIGN_HPP_
#define SPH_CALIB_DESIGN_HPP_

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/observability.hpp"
#include "sph/simulation/simulate.hpp"

namespace sph {

/// Predicted standard deviations of a design.
struct PredictedUncertainty {
  std::vector<ParameterDescription> parameters;  ///< the seven errors, then the centres
  Eigen::VectorXd std;                           ///< internal units (rad, mm); +inf where undetermined
  double condition_number = 0.0;                 ///< of the column-equilibrated weighted Jacobian
  /// Second-order bias of the least-squares estimate (Box 1971), internal units:
  ///   bias = -1/2 (J^T W J)^-1 J^T W d,  d_i = tr(C H_i),  H_i = d^2 e_i / dx^2 at the truth.
  /// Where the tangential errors scatter by tens of um (small eccentricity) their curvature shifts
  /// d' and the radius by a few nm: the estimator is then measurably biased, by this much.
  Eigen::VectorXd bias;

  /// Standard deviation of parameter i as a displacement [um] (angles times R0).
  double StdAsDisplacementUm(int i) const;
  /// Whether the design determines parameter i as a calibration judges it
  /// (CalibrationOptions::max_std_um): its std, as a displacement, is finite and at most
  /// max_std_um. An undetermined parameter's std and bias say nothing a linearisation can: the
  /// estimate is not held near the truth by the data.
  bool Determined(int i, double max_std_um) const { return StdAsDisplacementUm(i) <= max_std_um; }
  /// The largest StdAsDisplacementUm over the seven errors, and which error it is.
  double WorstErrorStdUm(int* which = nullptr) const;
};

/// Linearised (Cramer-Rao) standard deviations of every parameter for the design in `spec`
/// (truth, R0, d, centres, pattern, noise; the seed is not used).
PredictedUncertainty PredictUncertainty(const SimulationSpec& spec);

/// The smallest eccentricity e in [lo_mm, hi_mm] along `direction` (unit vector; with several
/// directions, one setup each, all at the same e) for which every one of the seven errors has a
/// predicted std, as a displacement, of at most target_um. Nothing when even hi_mm does not reach it.
std::optional<double> SmallestEccentricityMm(SimulationSpec spec, const std::vector<Eigen::Vector3d>& directions,
                                             double target_um, double lo_mm, double hi_mm);

}  // namespace sph

#endif  // SPH_CALIB_DESIGN_HPP_
