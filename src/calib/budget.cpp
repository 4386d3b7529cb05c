#include "sph/calib/budget.hpp"

#include <cmath>
#include <limits>
#include <utility>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using gum::BudgetInput;
using gum::EvaluationType;
using gum::kInfiniteDof;
using gum::UncertaintyStatement;

constexpr double kReferenceTemperatureC = 20.0;  // ISO 1: the temperature R0 is certified at
constexpr double kRadiusStepMm = 1e-2;           // +-10 um: the fit is linear in R0 far beyond
constexpr double kScaleStep = 1e-4;              // +-1e-4 of the probe reading

Eigen::VectorXd CentralDifference(const Eigen::VectorXd& plus, const Eigen::VectorXd& minus, double h,
                                  const char* what) {
  const Eigen::VectorXd s = (plus - minus) / (2.0 * h);
  if (!s.allFinite()) throw Error(std::string("uncertainty budget: the refit for the ") + what + " failed");
  return s;
}

PointsData WithProbeScale(const PointsData& points, double factor) {
  PointsData scaled = points;
  for (Sample& s : scaled.samples) s.r_mm *= factor;
  return scaled;
}

}  // namespace

double CalibrationInputs::RadiusAtTemperatureMm(double r0_at_20_mm) const {
  return r0_at_20_mm * (1.0 + sphere_cte_per_k * (sphere_temperature_c - kReferenceTemperatureC));
}

CalibrationInputs CalibrationInputs::With(const SphereConditions& stated) const {
  CalibrationInputs in = *this;
  if (stated.sphere_radius_u_um) in.sphere_radius_u_um = *stated.sphere_radius_u_um;
  if (stated.sphere_temperature_c) in.sphere_temperature_c = *stated.sphere_temperature_c;
  if (stated.sphere_temperature_u_c) in.sphere_temperature_u_c = *stated.sphere_temperature_u_c;
  if (stated.sphere_cte_per_k) in.sphere_cte_per_k = *stated.sphere_cte_per_k;
  if (stated.probe_scale_u) in.probe_scale_u = *stated.probe_scale_u;
  return in;
}

CalibrationBudget MakeCalibrationBudget(const PointsData& fitted, const CalibrationOptions& options,
                                        const CalibrationResult& fit, const CalibrationInputs& inputs,
                                        const BudgetRefit& refit) {
  CalibrationOptions o = options;
  o.prior_sigma_mm = fit.prior_sigma_mm;
  o.robust_sigma_mm = fit.robust_sigma_mm;
  return MakeCalibrationBudget(fitted, o, fit.analysis, fit.n_points, inputs, refit);
}

CalibrationBudget MakeCalibrationBudget(const PointsData& fitted, const CalibrationOptions& options,
                                        const ObservabilityReport& analysis, int n_points, const CalibrationInputs& in,
                                        const BudgetRefit& refit) {
  if (analysis.Empty()) throw Error("uncertainty budget: the fit was not analysed");
  const auto n = static_cast<Eigen::Index>(analysis.parameters.size());
  CalibrationBudget b;
  // The priors on parameters of the fit that it did not hold: inputs of their own.
  std::vector<std::pair<std::size_t, Eigen::Index>> priors;  // (prior, parameter)
  for (std::size_t k = 0; k < options.priors.size(); ++k) {
    for (Eigen::Index i = 0; i < n; ++i) {
      if (analysis.parameters[static_cast<std::size_t>(i)].name == options.priors[k].name &&
          !analysis.IsHeld(static_cast<int>(i))) {
        priors.emplace_back(k, i);
      }
    }
  }
  b.type_a_dof = analysis.degrees_of_freedom > 0.0 ? analysis.degrees_of_freedom
                                                   : static_cast<double>(n_points) - static_cast<double>(n);
  b.coverage = in.coverage;

  // Sensitivities by refits of the same readings, the search started where the fit ended.
  CalibrationOptions o = options;
  o.outlier_sigma = 0.0;
  o.analyse = false;
  const double r0 = options.sphere_radius_mm;
  CalibrationOptions plus = o, minus = o;
  plus.sphere_radius_mm = r0 + kRadiusStepMm;
  minus.sphere_radius_mm = r0 - kRadiusStepMm;
  const Eigen::VectorXd s_r0_per_mm =
      CentralDifference(refit(fitted, plus), refit(fitted, minus), kRadiusStepMm, "radius");
  const Eigen::VectorXd s_scale =
      CentralDifference(refit(WithProbeScale(fitted, 1.0 + kScaleStep), o),
                        refit(WithProbeScale(fitted, 1.0 - kScaleStep), o), kScaleStep, "probe scale");
  if (s_r0_per_mm.size() != n || s_scale.size() != n) {
    throw Error("uncertainty budget: the refit returned " + std::to_string(s_r0_per_mm.size()) + " parameters, not " +
                std::to_string(n));
  }
  const double r0_at_20 = r0 / (1.0 + in.sphere_cte_per_k * (in.sphere_temperature_c - kReferenceTemperatureC));
  const bool cte_given = in.sphere_cte_per_k > 0.0;

  BudgetSensitivity radius{"R0 (certificate)",     "R0", "um", in.sphere_radius_u_um, in.sphere_radius_dof,
                           s_r0_per_mm / kUmPerMm, ""};
  radius.note = in.sphere_radius_u_um > 0.0 ? "the certificate's standard uncertainty"
                                            : "not stated: R0 taken as exact (sphere_radius_u_um)";
  BudgetSensitivity temperature{"sphere temperature",
                                "temperature",
                                "K",
                                cte_given ? in.sphere_temperature_u_c : 0.0,
                                kInfiniteDof,
                                s_r0_per_mm * r0_at_20 * in.sphere_cte_per_k,
                                ""};
  temperature.note = !cte_given ? "no expansion coefficient stated (sphere_cte_per_k): R0 not corrected"
                     : in.sphere_temperature_u_c > 0.0
                         ? internal::Format("R0 corrected to %.3f deg C", in.sphere_temperature_c)
                         : "temperature uncertainty not stated (sphere_temperature_u_c)";
  BudgetSensitivity scale{"probe scale", "probe scale", "relative", in.probe_scale_u, kInfiniteDof, s_scale, ""};
  scale.note = in.probe_scale_u > 0.0 ? "of the probe reading" : "not stated (probe_scale_u)";
  b.inputs = {radius, temperature, scale};
  // Each prior by refits with its value moved by its own uncertainty (the fit is linear in it).
  Eigen::MatrixXd type_a = analysis.covariance;
  for (const auto& [k, i] : priors) {
    const ParameterPrior& prior = options.priors[k];
    CalibrationOptions moved_up = o, moved_down = o;
    moved_up.priors[k].value += prior.u;
    moved_down.priors[k].value -= prior.u;
    const std::string& name = analysis.parameters[static_cast<std::size_t>(i)].name;
    const Eigen::VectorXd per_internal =
        CentralDifference(refit(fitted, moved_up), refit(fitted, moved_down), prior.u, ("prior on " + name).c_str());
    const bool angle = analysis.parameters[static_cast<std::size_t>(i)].quantity == Quantity::kAngle;
    const double unit = angle ? 1.0 / kUradPerRad : kMmPerUm;  // internal units per urad or um
    BudgetSensitivity s{"prior on " + name,
                        "prior " + name,
                        angle ? "urad" : "um",
                        prior.u / unit,
                        kInfiniteDof,
                        per_internal * unit,
                        "the standard uncertainty of an independent measurement of it"};
    type_a -= s.per_unit * s.per_unit.transpose() * (s.u * s.u);
    b.inputs.push_back(s);
  }

  b.covariance = type_a;
  for (const BudgetSensitivity& s : b.inputs) b.covariance += s.per_unit * s.per_unit.transpose() * (s.u * s.u);

  for (Eigen::Index i = 0; i < n; ++i) {
    if (analysis.IsHeld(static_cast<int>(i))) {  // held: no uncertainty of its own
      UncertaintyStatement none;
      none.u = none.U = 0.0;
      b.statements.push_back(none);
      continue;
    }
    if (!analysis.determined[static_cast<std::size_t>(i)] || !std::isfinite(analysis.std(i))) {
      UncertaintyStatement none;
      none.u = none.U = std::numeric_limits<double>::infinity();
      b.statements.push_back(none);
      continue;
    }
    std::vector<BudgetInput> inputs;
    const double std_a = priors.empty() ? analysis.std(i) : std::sqrt(std::max(type_a(i, i), 0.0));
    inputs.push_back(
        {"fit (scatter of the points)", EvaluationType::kA, std_a, 1.0, b.type_a_dof, "", "the fit's covariance"});
    for (const BudgetSensitivity& s : b.inputs) {
      inputs.push_back({s.input, EvaluationType::kB, s.u, s.per_unit(i), s.dof, s.unit, s.note});
    }
    b.statements.push_back(gum::Combine(std::move(inputs), in.coverage));
  }
  return b;
}

}  // namespace sph
