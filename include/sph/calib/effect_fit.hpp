// Calibration with effects beyond the seven errors (sph/model/effects.hpp) and the sphere's form.
//
// Minimises
//   S = sum_i (|EffectScmsPoint(g, effects; reading_i) - O_setup(i)| - R_setup(i) - F(form; reading_i))^2
// over the seven errors g, one centre per setup, one parameter block per effect term and the form's
// coefficients, from a given start (usually the seven-error calibration, with the effects at zero),
// solved as every calibration is, by Ceres' Levenberg-Marquardt (ceres::Solve) on the
// hand-derived gradient (docs/architecture.md, "The solver"). With no terms and no form it is the
// seven-error calibration of sph/calib/calibrator.hpp. A term's size is data: it holds only the
// components the measurement determines (sph/select/trace.hpp leaves the others out).
//
// Plain C++ API: no Ceres type appears here. Units: rad and mm.
#ifndef SPH_CALIB_EFFECT_FIT_HPP_
#define SPH_CALIB_EFFECT_FIT_HPP_

#include <vector>

#include <Eigen/Core>

#include "sph/calib/calibrator.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/effects.hpp"

namespace sph {

/// Where a fit with effects starts.
struct EffectFit;

struct EffectFitStart {
  ScmsGeometry geometry{};                  ///< (rad, mm)
  std::vector<Eigen::Vector3d> centers_mm;  ///< one per setup, ascending setup id
  /// One block per term of the model (rad, mm); missing or wrongly sized blocks start at zero.
  std::vector<std::vector<double>> values;
  /// One block of form coefficients per group of the model's form [mm]; as values.
  std::vector<std::vector<double>> form_values;

  /// The seven-error calibration's solution, effects at zero.
  static EffectFitStart From(const CalibrationResult& calibration);
  /// Where `fit` ended: its seven errors, centres, effects and form (to refit the same model).
  static EffectFitStart From(const EffectFit& fit);
};

/// The outcome of a fit with effects.
struct EffectFit {
  /// The seven errors, centres, residuals (file order), rms, peak-to-valley and warnings. When
  /// analysed, `calibration.analysis` covers every parameter: the seven errors, x, y, z of each
  /// centre, then the effects' parameters in term order.
  CalibrationResult calibration;
  EffectModel model;
  std::vector<std::vector<double>> values;  ///< one block per term (rad, mm)
  /// The form's coefficients [mm], one block per group of model.form (empty without a form).
  std::vector<std::vector<double>> form_values;
  double rss_mm2 = 0.0;  ///< sum of squared residuals
  int n_params = 0;      ///< fitted parameters in all
  /// sum over the fitted readings of ln |d r_true / d r_read| (ReadingSlope()): a probe's gain or
  /// nonlinearity stretches the readings' noise by that slope along with the readings.
  double log_reading_slope = 0.0;

  /// Bayesian information criterion of the fit, with the readings' Gaussian noise as its
  /// likelihood: m ln(RSS / m) - 2 log_reading_slope + n ln(m). The residuals are those of the
  /// corrected readings, whose noise a gain of slope 1 + k scales by 1 + k: without the slope's
  /// term a gain with k < 0 would lower the BIC by 2 m |ln(1 + k)| for shrinking the noise alone.
  double Bic() const;
  /// Index of the first parameter of term `term` in the analysis' parameter list.
  int TermOffset(std::size_t term) const;
  /// Index of the first form coefficient of group `group` in the analysis' parameter list.
  int FormOffset(int group) const;
};

/// Fits `model` (its reference as given) to `points` from `start`. With options.analyse the
/// Jacobian, covariance, VIF and determinacy are computed too. Throws sph::Error as Calibrate().
EffectFit FitEffects(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                     const EffectFitStart& start);

/// The form model of `terms` for the setups of `points`: the setups of known orientation (the
/// header's mount_rotation_deg, or none: the reference orientation) share one coefficient set,
/// each setup of unknown orientation has its own. No terms: no form.
FormModel FormModelOf(const PointsData& points, const std::vector<FormTerm>& terms);

/// F [mm] of the form of `fit` seen by setup `setup_id` at the direction `offset` (p - O, any
/// length, in the sphere frame); 0 without a form.
double FormAt(const EffectFit& fit, int setup_id, const Eigen::Vector3d& offset);

/// The Jacobian of the residuals of `points` (rows in file order) at the parameters of `fit`,
/// columns as the analysis' parameters. Every setup of `points` must be one of the fit's. (The fit
/// itself never holds it: its analysis uses the Jacobian's triangular factor, accumulated row
/// block by row block.)
Eigen::MatrixXd JacobianAt(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit);

/// p - O [mm] of each sample of `points` (file order) under the parameters of `fit`: the probed
/// point relative to its setup's centre, in the sphere frame (the form of the sphere, which moves
/// the surface and not the point, does not enter). Throws sph::Error as EffectResiduals().
std::vector<Eigen::Vector3d> OffsetsFromCentre(const PointsData& points, const CalibrationOptions& options,
                                               const EffectFit& fit);

/// Residuals |p - O| - R0 - F(R^T (p - O) / |p - O|) [mm] of the samples of `points`, in file order,
/// under the parameters of `fit` (F: the form of the setup's group, none without a form). Every
/// setup of `points` must be one of the fit's; throws sph::Error otherwise.
std::vector<double> EffectResiduals(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit);

}  // namespace sph

#endif  // SPH_CALIB_EFFECT_FIT_HPP_
