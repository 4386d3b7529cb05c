// Uncertainty and identifiability of a least-squares fit from its Jacobian at the solution.
//
// With J (m x n) the Jacobian of the residuals, s^2 = sum(e^2) / (m - n) the residual variance:
//   covariance = s^2 (J^T J)^-1, computed through the SVD of J D (or of R D, J = Q R) with
// D = diag(1 / |J_:,j|) (column equilibration, so the units of the parameters do not matter). The condition number is
// that of J D; the right singular vectors of its smallest singular values are the nearly dependent
// parameter combinations. A parameter is undetermined when its standard uncertainty, as a
// displacement of the probed point (lengths as they are, angles times a lever arm), exceeds a
// threshold, or when it lies in the numerical null space of J.
#ifndef SPH_CALIB_OBSERVABILITY_HPP_
#define SPH_CALIB_OBSERVABILITY_HPP_

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/model/scms_model.hpp"

namespace sph {

/// A fitted parameter as the analysis sees it.
struct ParameterDescription {
  std::string name;  ///< "alpha", ..., "center_x", or "center_x@1" with several setups
  Quantity quantity = Quantity::kLength;
  double lever_mm = 1.0;  ///< for angles: the arm that turns an angle into a displacement [mm]
};

/// One nearly dependent combination of parameters.
struct WeakCombination {
  double relative_singular_value = 0.0;  ///< sigma_k / sigma_max of the equilibrated Jacobian
  /// Parameter index and coefficient. The coefficients are displacement-equivalent (angles times
  /// their lever arm) and scaled so that the largest magnitude is 1; only those >= 0.1 are kept.
  std::vector<std::pair<int, double>> terms;
};

/// How a parameter entered a fit.
enum class Held {
  kNo,            ///< fitted
  kFixed,         ///< held at a value given (CalibrationOptions::fixed)
  kAtLowerBound,  ///< fitted, but ended at its lower bound: held there
  kAtUpperBound,  ///< ... at its upper bound
};

struct ObservabilityReport {
  std::vector<ParameterDescription> parameters;
  /// Per parameter; empty: every one fitted. A held parameter has std 0, no covariance with the
  /// others (zero), no correlation (NaN) and counts as determined; the rest of the analysis is
  /// that of the fit of the others.
  std::vector<Held> held;
  Eigen::VectorXd std;         ///< standard uncertainty, internal units; +inf in the null space
  Eigen::MatrixXd covariance;  ///< internal units (rad, mm); rows of null-space parameters are NaN
  Eigen::MatrixXd correlation;
  std::vector<bool> determined;
  /// Variance inflation factor of each parameter: its variance over what it would be were its
  /// column of the Jacobian orthogonal to all others (1: independent; +inf: in the null space).
  /// 1 - 1/vif is the squared multiple correlation with the other parameters.
  Eigen::VectorXd vif;
  double residual_sigma_mm = 0.0;  ///< s = sqrt(sum e^2 / dof)
  /// The degrees of freedom of s: m - n, or with priors m - n plus what the priors determine of
  /// the parameters (the sum of their leverages; see src/calib/solve_fit.hpp).
  double degrees_of_freedom = 0.0;
  double condition_number = 0.0;      ///< of the column-equilibrated Jacobian
  std::vector<WeakCombination> weak;  ///< weakest first

  bool Empty() const { return parameters.empty(); }
  bool AllDetermined() const;
  bool IsHeld(int i) const { return !held.empty() && held[static_cast<std::size_t>(i)] != Held::kNo; }
  /// Standard uncertainty of parameter i as a displacement [um] (angles times their lever arm).
  double StdAsDisplacementUm(int i) const;
  /// The undetermined parameters for a message, each with its std as a displacement: "beta (std
  /// 3.2 um), c (no information at all)"; empty when every parameter is determined.
  std::string UndeterminedText() const;
};

/// (J^T J)^-1 through the SVD of the column-equilibrated J D (see the file comment), and what the
/// SVD tells about J. Singular values below max(m, n) * eps * sigma_max count as zero; a parameter
/// with a component above 1e-6 in their right singular vectors (or a zero column) is in the null space.
struct NormalInverse {
  Eigen::MatrixXd inverse;        ///< (J^T J)^-1; rows and columns of null-space parameters are NaN
  std::vector<bool> in_null;      ///< parameter j lies in the numerical null space of J
  double condition_number = 0.0;  ///< sigma_max / sigma_min of J D (inf when singular)
  /// Of J D, descending: all of them, or (a fit of many setups, analysed through its block
  /// structure) the largest and the weakest ones.
  Eigen::VectorXd singular_values;
  Eigen::MatrixXd v;      ///< right singular vectors of J D, in the same order
  Eigen::VectorXd scale;  ///< the diagonal of D: 1 / |J_:,j|, 0 for a zero column
};

/// NormalInverse of a Jacobian with at least as many rows as columns.
NormalInverse InvertNormalMatrix(const Eigen::MatrixXd& jacobian);

/// The same from the triangular factor R of the Jacobian (J = Q R, R square) and J's number of
/// rows: R D has the singular values and right singular vectors of J D, so nothing of size
/// rows x columns is needed (sph/model/row_qr.hpp accumulates R from blocks of rows).
NormalInverse InvertNormalFactor(const Eigen::MatrixXd& r, Eigen::Index rows);

/// The ratio of largest to smallest eigenvalue of the equilibrated normal matrix below which
/// InvertNormalEquations() answers: the square of a condition number of 1e4.
inline constexpr double kMaxNormalCondition = 1e8;

/// The same from the normal matrix J^T J (full, symmetric) when J is well conditioned: the
/// eigenvalues of D J^T J D are the squares of the singular values of J D and its eigenvectors are
/// V, with relative errors of about eps * cond(J D)^2 <= 1e-8 when cond(J D)^2 < kMaxNormalCondition
/// (then nothing is near the null space either). Empty otherwise: use the factor.
std::optional<NormalInverse> InvertNormalEquations(const Eigen::MatrixXd& jtj, Eigen::Index rows);

/// Analyses a fit. `jacobian` is m x n with m > n, `residuals` has m entries (any unit, the same
/// as the Jacobian's rows), `params` describes the n columns.
ObservabilityReport AnalyseFit(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residuals,
                               std::vector<ParameterDescription> params, double max_std_um);

/// AnalyseFit() from the triangular factor R of the Jacobian (see InvertNormalFactor()), its number
/// of rows and the residuals' sum of squares.
ObservabilityReport AnalyseFactor(const Eigen::MatrixXd& r, Eigen::Index rows, double rss,
                                  std::vector<ParameterDescription> params, double max_std_um);

/// AnalyseFit() from the inverse of the normal matrix as any of the functions above gives it.
ObservabilityReport AnalyseFit(const NormalInverse& inverse, Eigen::Index rows, double rss,
                               std::vector<ParameterDescription> params, double max_std_um);

/// The report `free` of the parameters a fit did not hold as one of all its `parameters`, `held`
/// saying which it held (see ObservabilityReport::held).
ObservabilityReport WithHeldParameters(const ObservabilityReport& free, std::vector<ParameterDescription> parameters,
                                       const std::vector<Held>& held);

}  // namespace sph

#endif  // SPH_CALIB_OBSERVABILITY_HPP_
