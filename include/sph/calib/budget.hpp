// The uncertainty budget of a calibration, as a calibration laboratory states it (GUM).
//
// The fit's covariance is the Type A evaluation: the scatter of the points about the model. It
// says nothing about what the fit takes as exact: the reference sphere's radius R0 (its
// certificate gives it with an uncertainty, and a steel ball grows with temperature) and the
// scale of the probe. Each of these is a Type B input x_j; its sensitivity vector
// s_j = d(parameters)/dx_j is measured by refitting the same readings (outliers left out as in
// the fit) with x_j moved by +-h and taking the central difference: exact for any model the
// refit function fits, the seven errors alone or with effects, and checked in the tests against
// the linearisation (J^T J)^-1 J^T de/dx_j of the seven-error fit.
//
// For each parameter p_i (GUM 5.1.2, with the inputs uncorrelated):
//   u_c(p_i)^2 = std_A(p_i)^2 + sum_j (s_ji u(x_j))^2,
// degrees of freedom by Welch-Satterthwaite (Type A: m - n, Type B as stated, infinite by
// default), coverage factor k (2 by default, or from a coverage probability and nu_eff) and
// U = k u_c. The combined covariance of all parameters, C = C_A + sum_j s_j s_j^T u(x_j)^2, is
// what a calibration file should carry for the measurements made with it.
//
// Temperature: the certificate states R0 at 20 deg C; at the measuring temperature T the sphere
// has R0(T) = R0 (1 + cte (T - 20 deg C)), which the fit then uses, and u(T) enters through
// s_R0 R0 cte. The uncertainty of the expansion coefficient itself is not an input (its
// contribution, R0 (T - 20) u(cte), is below 0.01 um for T within 1 K of 20 deg C).
#ifndef SPH_CALIB_BUDGET_HPP_
#define SPH_CALIB_BUDGET_HPP_

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/calibrator.hpp"
#include "sph/core/gum.hpp"
#include "sph/core/points_file.hpp"

namespace sph {

/// The Type B inputs of a calibration and how its uncertainties are expanded. Defaults: what a
/// points file without the fields says; the report names each default it used.
struct CalibrationInputs {
  double sphere_radius_u_um = 0.0;  ///< u(R0) from the certificate, k = 1 [um]; 0: not stated
  double sphere_radius_dof = gum::kInfiniteDof;
  double sphere_temperature_c = 20.0;   ///< while measured [deg C]; R0 is certified at 20 deg C
  double sphere_temperature_u_c = 0.0;  ///< [K]
  double sphere_cte_per_k = 0.0;        ///< [1/K]; 0: not stated (no correction of R0)
  double probe_scale_u = 0.0;           ///< relative [1]
  gum::CoverageSpec coverage;           ///< k = 2 unless a coverage probability is given

  /// R0 at the measuring temperature: R0_20 (1 + cte (T - 20 deg C)) [mm].
  double RadiusAtTemperatureMm(double r0_at_20_mm) const;
  /// The inputs a points file states, the rest as given here.
  CalibrationInputs With(const SphereConditions& stated) const;
};

/// One Type B input's effect on every parameter.
struct BudgetSensitivity {
  std::string input;   ///< "R0 (certificate)", "sphere temperature", "probe scale"
  std::string column;  ///< a short name for a table column: "R0", "temperature", "probe"
  std::string unit;    ///< of the input: "um", "K", "relative"
  double u = 0.0;      ///< its standard uncertainty, in `unit`
  double dof = gum::kInfiniteDof;
  Eigen::VectorXd per_unit;  ///< d(parameter)/d(input) per `unit`, internal units (rad, mm)
  std::string note;          ///< where u comes from, or that it is a default
};

/// The budget of every parameter of a fit.
struct CalibrationBudget {
  std::vector<BudgetSensitivity> inputs;
  /// One statement per parameter (the analysis' order), in internal units (rad, mm); a parameter
  /// the data do not determine has u = infinity and no budget.
  std::vector<gum::UncertaintyStatement> statements;
  Eigen::MatrixXd covariance;  ///< combined covariance, internal units
  double type_a_dof = 0.0;     ///< m - n
  gum::CoverageSpec coverage;  ///< how U was formed
};

/// Refits the readings with changed options (radius) or readings (probe scale) and returns every
/// parameter in the analysis' order, internal units.
using BudgetRefit = std::function<Eigen::VectorXd(const PointsData&, const CalibrationOptions&)>;

/// The budget of a fit (see the file comment). `fitted`: the readings the fit used (outliers
/// left out); `analysis`: the fit's covariance and determinacy; `n_points`: m. Each prior of
/// `options` on a parameter of the analysis is an input of its own (its standard uncertainty,
/// the sensitivity by refits with its value moved), and the fit's covariance less what the priors
/// contribute to it is the Type A part; the refits weight the priors (and scale a robust loss) by
/// the noise of `options` (prior_sigma_mm, robust_sigma_mm: the fit's). A held parameter has no
/// uncertainty. Throws sph::Error if the refits fail.
CalibrationBudget MakeCalibrationBudget(const PointsData& fitted, const CalibrationOptions& options,
                                        const ObservabilityReport& analysis, int n_points,
                                        const CalibrationInputs& inputs, const BudgetRefit& refit);

/// The same for the fit `fit` of `fitted` under `options`: its analysis, number of readings and
/// the noise its priors and robust loss were scaled by.
CalibrationBudget MakeCalibrationBudget(const PointsData& fitted, const CalibrationOptions& options,
                                        const CalibrationResult& fit, const CalibrationInputs& inputs,
                                        const BudgetRefit& refit);

}  // namespace sph

#endif  // SPH_CALIB_BUDGET_HPP_
