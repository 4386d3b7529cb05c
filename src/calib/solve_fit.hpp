// Private to sph::calib: every fit's solve and analysis with what CalibrationOptions holds,
// informs, bounds and weights (fixed parameters, priors, bounds, a robust loss).
//
// - Fixed: the columns held at their value (given, or where the fit starts).
// - Priors: the residual (p - value) sigma / u beside the readings', sigma the readings' noise:
//   given (CalibrationOptions::prior_sigma_mm), else first the fit with the informed parameters
//   held at their values, then refits until sigma^2 = RSS / (m - n + L) holds to 1e-3, RSS the
//   readings' and L the priors' leverage, sum_j (sigma / u_j)^2 [(J^T J + P)^-1]_jj: what they
//   determine of the parameters, 1 for a prior of a tiny uncertainty (a fix), 0 for a huge one.
// - Bounds: the physical ones (|alpha|, |beta|, |epsilon| < 90 deg, d' > -d) and the options'. A
//   parameter that ends at one is held there for the analysis.
// - A robust loss: first least squares, then the loss at robust_scale_sigma times the noise (1.4826
//   median absolute deviation of the residuals, each setup about its own median), refitted until
//   the noise holds to 1e-3; the analysis weighs each reading by rho'(e^2) (the last step of
//   iteratively reweighted least squares).
// The analysis is that of the free parameters, the priors' rows with the readings' (rows m +
// priors), expanded to all with the held ones marked (WithHeldParameters()). Without any of these
// both are as they were: the solve of ceres_fit.hpp, the analysis of NormalInverseAtSolution().
#ifndef SPH_SRC_CALIB_SOLVE_FIT_HPP_
#define SPH_SRC_CALIB_SOLVE_FIT_HPP_

#include <vector>

#include <Eigen/Core>

#include "ceres_fit.hpp"
#include "fit_problem.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/observability.hpp"

namespace sph::internal {

/// What solving leaves for the analysis.
struct SolvedFit {
  std::vector<Held> held;           ///< per column of x
  std::vector<ColumnPrior> priors;  ///< on free columns
  ColumnsPrior form_prior;          ///< CalibrationOptions::form_prior on the columns of the model's form
  double prior_sigma_mm = 0.0;
  std::vector<double> weights;  ///< each reading's rho'(e^2) (table-indexed; empty without a loss)

  /// Nothing held, informed or weighted: the plain least-squares fit.
  bool Plain() const;
};

/// CalibrationOptions::form_prior on the columns of `problem`'s form of the setups of known
/// orientation (group 0), then each of other_form_priors on its sphere's set: each prior's terms
/// that the model has, their marginal, the whitening block diagonal by set; empty when the model
/// has no form or form_prior is empty; a setup of other_form_priors the model's form lacks is left
/// out. Throws sph::Error when such a setup is in group 0's set, or two name the same set.
ColumnsPrior FormPriorColumns(const SphereFitProblem& problem, const CalibrationOptions& options);

/// (J^T J + P)^-1 at x: the readings' rows with the rows of the options' priors and form prior
/// (P, weighted with the readings' noise prior_sigma_mm, as SolveFit() weighs them), every column
/// free; NormalInverseAtSolution() when the options inform nothing or prior_sigma_mm is not
/// positive. What the data and the priors together separate before any fit.
NormalInverse InformedInverseAt(const SphereFitProblem& problem, const Eigen::VectorXd& x,
                                const CalibrationOptions& options, double prior_sigma_mm);

/// Throws sph::Error naming `source` when the options' fixed, prior and bound parameters are not
/// parameters of a calibration, are given twice, or a parameter is both held and informed.
void CheckParameterSettings(const CalibrationOptions& options, const std::string& source);

/// Solves `problem` from x (in place) under `options` and records the run in `result`: converged,
/// iterations, the solver's message, n_samples, a warning when it did not converge, the robust
/// loss' noise and scale and the priors' sigma. Throws sph::Error naming `source` when x starts outside a bound.
SolvedFit SolveFit(const SphereFitProblem& problem, Eigen::VectorXd& x, const CalibrationOptions& options,
                   std::size_t n_samples, CalibrationResult& result, const std::string& source);

/// The readings' sum of squares, weighted by the loss [mm^2]; `residuals`: table-indexed.
double WeightedRss(const SphereFitProblem& problem, const SolvedFit& solved, const std::vector<double>& residuals);

/// The analysis of a solved fit: every parameter of `desc`, the held ones marked. `rss`: the
/// readings' (weighted) sum of squares; their variance is rss over m - n_free plus the priors'
/// leverage (a prior of a tiny uncertainty counts as a fix, one of a huge uncertainty as none).
ObservabilityReport AnalyseSolved(const SphereFitProblem& problem, const Eigen::VectorXd& x, const SolvedFit& solved,
                                  double rss, std::vector<ParameterDescription> desc, double max_std_um);

/// Under a robust loss, the readings it weighted down into result.weighted (file order) and a
/// warning that names the strongest; `residuals` table-indexed.
void NoteWeightedReadings(const PointsData& points, const SolvedFit& solved, const std::vector<double>& residuals,
                          CalibrationResult& result);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_SOLVE_FIT_HPP_
