// Private to sph::calib: the checks, parameter descriptions, analysis and residual statistics of
// every fit.
#ifndef SPH_SRC_CALIB_PROBLEM_EVAL_HPP_
#define SPH_SRC_CALIB_PROBLEM_EVAL_HPP_

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ceres_fit.hpp"
#include "fit_problem.hpp"
#include "solve_fit.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/observability.hpp"
#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph::internal {

/// Throws sph::Error naming the points' source when the options cannot fit them: a sphere radius
/// or the probe offset not positive, a setup that the header says measured another sphere without
/// its radius in the options, a known form of another sphere without the reference sphere's or by
/// a setup that measured no other sphere in a known orientation.
inline void CheckFitOptions(const PointsData& points, const CalibrationOptions& options) {
  const std::string& source = points.source;
  CheckParameterSettings(options, source);
  if (!(options.sphere_radius_mm > 0.0)) throw Error(source + ": the sphere radius must be positive");
  if (!(options.probe_offset_mm > 0.0)) throw Error(source + ": the probe offset must be positive");
  for (const auto& [setup, radius_mm] : options.sphere_radii_mm) {
    if (!(radius_mm > 0.0)) {
      throw Error(source + ": the radius of the sphere of setup " + std::to_string(setup) + " must be positive");
    }
  }
  for (const auto& [setup, radius_mm] : points.header.sphere_radii_mm) {
    if (options.sphere_radii_mm.count(setup) == 0) {
      throw Error(source + ": setup " + std::to_string(setup) + " measured another sphere (" + SphereRadiusKey(setup) +
                  "), but the fit was given no radius for it");
    }
  }
  if (!options.other_form_priors.empty() && options.form_prior.Empty()) {
    throw Error(source + ": a known form of another sphere needs the reference sphere's form known too");
  }
  for (const auto& [setup, prior] : options.other_form_priors) {
    const auto rotation = points.header.mount_rotations.find(setup);
    if (points.header.sphere_radii_mm.count(setup) == 0 ||
        (rotation != points.header.mount_rotations.end() && !rotation->second.known())) {
      throw Error(source + ": the known form of another sphere is given by setup " + std::to_string(setup) +
                  ", which did not measure another sphere in a known orientation");
    }
  }
}

/// Throws sph::Error naming `source` when n_samples do not exceed the n_params fitted (`which`:
/// what they are, in words, or empty).
inline void CheckEnoughSamples(const std::string& source, std::size_t n_samples, std::size_t n_params,
                               const std::string& which) {
  if (n_samples > n_params) return;
  throw Error(source + ": " + std::to_string(n_samples) + " samples are too few to fit " + std::to_string(n_params) +
              " parameters" + (which.empty() ? "" : " (" + which + ")"));
}

/// (J^T J)^-1 at x: with many setups through the Jacobian's block structure (block_factor.hpp),
/// else from the normal equations when J is well conditioned, else from
/// the Jacobian's triangular factor (another pass over the rows).
inline NormalInverse NormalInverseAtSolution(const SphereFitProblem& problem, const Eigen::VectorXd& x) {
  const auto rows = static_cast<Eigen::Index>(problem.NumRows());
  const auto shared = static_cast<int>(problem.NumParams()) - 3 * problem.NumSetups();
  if (AnalyseByBlocks(problem.NumSetups(), shared)) return problem.FactorBlocks(x.data()).Invert();
  NormalEquations at_x;
  problem.Evaluate(x.data(), &at_x);
  std::optional<NormalInverse> inverse = InvertNormalEquations(at_x.jtj, rows);
  if (inverse) return *inverse;
  return InvertNormalFactor(problem.FactorJacobian(x.data()).r(), rows);
}

/// The descriptions of the seven errors and of x, y, z of each setup's centre ("center_x@1" with
/// several setups), in the order of every calibration's parameter list.
inline std::vector<ParameterDescription> BaseParameterDescriptions(const std::vector<int>& setup_ids,
                                                                   double sphere_radius_mm) {
  std::vector<ParameterDescription> desc;
  for (const auto& info : kScmsParamInfo) desc.push_back({info.name, info.quantity, sphere_radius_mm});
  for (int id : setup_ids) {
    const std::string suffix = setup_ids.size() > 1 ? "@" + std::to_string(id) : "";
    for (const char* axis : {"center_x", "center_y", "center_z"})
      desc.push_back({axis + suffix, Quantity::kLength, 1.0});
  }
  return desc;
}

/// BaseParameterDescriptions() followed by the effects' parameters in term order and the form's
/// coefficients per group: every parameter of a fit of `model`, in the analysis' order.
inline std::vector<ParameterDescription> ParameterDescriptions(const std::vector<int>& setup_ids,
                                                               const EffectModel& model, double sphere_radius_mm) {
  std::vector<ParameterDescription> desc = BaseParameterDescriptions(setup_ids, sphere_radius_mm);
  for (const EffectTerm& term : model.terms) {
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      desc.push_back({term.ParamName(i), term.info().quantity, sphere_radius_mm});
    }
  }
  for (int group = 0; group < model.form.NumGroups() && !model.form.Empty(); ++group) {
    for (std::size_t k = 0; k < model.form.terms.size(); ++k) {
      desc.push_back({model.form.ParamName(group, k), Quantity::kLength, sphere_radius_mm});
    }
  }
  return desc;
}

/// result.rms_um and result.pv_um from result.residuals_mm.
inline void SetResidualStatistics(CalibrationResult& result) {
  const Eigen::Map<const Eigen::VectorXd> res(result.residuals_mm.data(),
                                              static_cast<Eigen::Index>(result.residuals_mm.size()));
  if (res.size() == 0) return;
  result.rms_um = std::sqrt(res.squaredNorm() / static_cast<double>(res.size())) * kUmPerMm;
  result.pv_um = (res.maxCoeff() - res.minCoeff()) * kUmPerMm;
}

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_PROBLEM_EVAL_HPP_
