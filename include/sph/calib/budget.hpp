// The uncertainty budget of a calibration, as a calibration laboratory states it (GUM): for each
// parameter, the fit's Type A standard uncertainty and the Type B inputs the fit takes as exact
// (the reference sphere's radius from its certificate, its temperature, the probe's scale), each
// with a sensitivity vector s_j = d(parameters)/dx_j measured by refitting the same readings with
// x_j moved by +-h (central differences); the combined u, Welch-Satterthwaite degrees of freedom,
// k and U = k u; and the combined covariance C = C_A + sum_j s_j s_j^T u(x_j)^2 that a calibration
// file carries. The method in full: docs/method/uncertainty.md. Units: rad and mm (parameters),
// um, K and relative (inputs).
#ifndef SPH_CALIB_BUDGET_HPP_
#define SPH_CALIB_BUDGET_HPP_

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/calibrator.hpp"
#include "sph/stats/gum.hpp"
#include "sph/io/points_file.hpp"

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

/// The budget of a fit (docs/method/uncertainty.md). `fitted`: the readings the fit used (outliers
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
