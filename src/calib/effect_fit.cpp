// Calibration with effects: one dynamic-autodiff cost function per setup over all its readings.
#include "sph/calib/effect_fit.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <utility>

#include "problem_eval.hpp"
#include "sph/ceres/jet_sincos.hpp"
#include "sph/core/error.hpp"

namespace sph {
namespace {

// The residuals of one setup's readings. Parameter blocks: geometry[7], center[3], then one block
// per effect term. Ceres' DynamicAutoDiffCostFunction differentiates it in passes of kStride
// parameters, because the number of parameters depends on the model.
struct SetupResiduals {
  const EffectModel* model;
  std::vector<EffectReading> readings;
  double probe_offset_mm;
  double sphere_radius_mm;
  std::vector<double> basis;  // EffectBasisOf() of each reading, one after the other

  void Add(const Sample& s) {
    readings.emplace_back(s.theta_deg, s.phi_deg, s.r_mm, s.t_s);
    const std::vector<double> b = EffectBasisOf(*model, readings.back());
    basis.insert(basis.end(), b.begin(), b.end());
  }

  template <typename T>
  bool operator()(T const* const* params, T* residuals) const {
    using std::sqrt;
    const T* g = params[0];
    const T* center = params[1];
    const ScmsErrorTrig<T> trig = ErrorTrigOf(g);
    const auto stride = static_cast<std::size_t>(model->NumParams());
    for (std::size_t i = 0; i < readings.size(); ++i) {
      const Vec3<T> p =
          EffectScmsPoint(g, trig, *model, params + 2, readings[i], probe_offset_mm, basis.data() + i * stride);
      const T dx = p[0] - center[0], dy = p[1] - center[1], dz = p[2] - center[2];
      residuals[i] = sqrt(dx * dx + dy * dy + dz * dz) - T(sphere_radius_mm);
      if (!internal::AllFinite(residuals[i])) return false;
    }
    return true;
  }
};
constexpr int kStride = 16;

std::map<int, std::size_t> IndexOfSetups(const std::vector<int>& ids) {
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < ids.size(); ++k) index[ids[k]] = k;
  return index;
}

// The parameter blocks of a fit with effects, and the problem over them: one cost function per
// setup over all its readings. Blocks and problem live together, so that the problem's pointers
// stay valid.
struct EffectProblem {
  ScmsGeometry geometry{};
  std::vector<std::array<double, 3>> centers;
  std::vector<std::vector<double>> values;
  ceres::Problem problem;
  std::vector<std::size_t> sample_of_row;  // the sample (file row) of each residual, in Ceres' order

  EffectProblem(const PointsData& points, const CalibrationOptions& options, const EffectModel* model,
                const std::vector<int>& setup_ids, const ScmsGeometry& g, const std::vector<Eigen::Vector3d>& c,
                std::vector<std::vector<double>> v)
      : geometry(g), values(std::move(v)) {
    const std::map<int, std::size_t> setup_index = IndexOfSetups(setup_ids);
    for (const auto& x : c) centers.push_back({x.x(), x.y(), x.z()});
    std::vector<std::unique_ptr<SetupResiduals>> functors(setup_ids.size());
    std::vector<std::vector<std::size_t>> rows_of_setup(setup_ids.size());
    for (auto& f : functors) {
      f = std::make_unique<SetupResiduals>(
          SetupResiduals{model, {}, options.probe_offset_mm, options.sphere_radius_mm, {}});
    }
    for (std::size_t i = 0; i < points.samples.size(); ++i) {
      const std::size_t k = setup_index.at(points.samples[i].setup);
      rows_of_setup[k].push_back(i);
      functors[k]->Add(points.samples[i]);
    }
    for (std::size_t k = 0; k < functors.size(); ++k) {
      const int n_res = static_cast<int>(functors[k]->readings.size());
      auto* cost = new ceres::DynamicAutoDiffCostFunction<SetupResiduals, kStride>(functors[k].release());
      std::vector<double*> blocks{geometry.data(), centers[k].data()};
      cost->AddParameterBlock(kNumScmsParams);
      cost->AddParameterBlock(3);
      for (auto& b : values) {
        cost->AddParameterBlock(static_cast<int>(b.size()));
        blocks.push_back(b.data());
      }
      cost->SetNumResiduals(n_res);
      problem.AddResidualBlock(cost, nullptr, blocks);
      sample_of_row.insert(sample_of_row.end(), rows_of_setup[k].begin(), rows_of_setup[k].end());
    }
  }

  /// Every parameter block, in the order of the Jacobian's columns.
  std::vector<double*> Blocks() {
    std::vector<double*> blocks{geometry.data()};
    for (auto& c : centers) blocks.push_back(c.data());
    for (auto& v : values) blocks.push_back(v.data());
    return blocks;
  }
};

}  // namespace

Eigen::MatrixXd JacobianAt(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  EffectProblem p(points, options, &fit.model, fit.calibration.setup_ids, fit.calibration.geometry,
                  fit.calibration.centers_mm, fit.values);
  std::vector<double> residuals;
  Eigen::MatrixXd jac;
  internal::EvaluateInFileOrder(p.problem, p.Blocks(), p.sample_of_row, fit.n_params, &residuals, &jac);
  return jac;
}

EffectFitStart EffectFitStart::From(const CalibrationResult& calibration) {
  EffectFitStart s;
  s.geometry = calibration.geometry;
  s.centers_mm = calibration.centers_mm;
  return s;
}

double EffectFit::Bic() const {
  const double m = static_cast<double>(calibration.residuals_mm.size());
  // Residuals of exact data can be zero: no fit is better than rounding (1e-12 mm).
  return m * std::log(std::max(rss_mm2 / m, 1e-24)) + n_params * std::log(m);
}

int EffectFit::TermOffset(std::size_t term) const {
  int offset = kNumScmsParams + 3 * static_cast<int>(calibration.centers_mm.size());
  for (std::size_t i = 0; i < term; ++i) offset += model.terms[i].size();
  return offset;
}

EffectFit FitEffects(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                     const EffectFitStart& start) {
  const std::string& src = points.source;
  if (!(options.sphere_radius_mm > 0.0)) throw Error(src + ": the sphere radius must be positive");
  if (!(options.probe_offset_mm > 0.0)) throw Error(src + ": the probe offset must be positive");
  EffectFit fit;
  fit.model = model;
  CalibrationResult& result = fit.calibration;
  result.setup_ids = points.SetupIds();
  const std::size_t n_setups = result.setup_ids.size();
  if (start.centers_mm.size() != n_setups) throw Error(src + ": the start needs one centre per setup");
  fit.n_params = kNumScmsParams + 3 * static_cast<int>(n_setups) + model.NumParams();
  if (points.samples.size() <= static_cast<std::size_t>(fit.n_params)) {
    throw Error(src + ": " + std::to_string(points.samples.size()) + " samples are too few to fit " +
                std::to_string(fit.n_params) + " parameters");
  }
  std::vector<std::vector<double>> values(model.terms.size());
  for (std::size_t t = 0; t < model.terms.size(); ++t) {
    const auto size = static_cast<std::size_t>(model.terms[t].size());
    if (t < start.values.size() && start.values[t].size() == size) {
      values[t] = start.values[t];
    } else {
      values[t].assign(size, 0.0);
    }
  }
  EffectProblem p(points, options, &fit.model, result.setup_ids, start.geometry, start.centers_mm, std::move(values));
  ceres::Solver::Summary summary;
  ceres::Solve(internal::CalibrationSolverOptions(options.max_iterations), &p.problem, &summary);
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.solver_message = summary.message;
  result.n_points = static_cast<int>(points.samples.size());
  result.geometry = p.geometry;
  for (const auto& c : p.centers) result.centers_mm.emplace_back(c[0], c[1], c[2]);
  fit.values = p.values;
  if (!result.converged) result.warnings.push_back("the solver did not converge: " + summary.message);
  internal::EvaluateInFileOrder(p.problem, p.Blocks(), p.sample_of_row, fit.n_params, &result.residuals_mm,
                                options.analyse ? &fit.jacobian : nullptr);
  internal::SetResidualStatistics(result);
  for (double e : result.residuals_mm) fit.rss_mm2 += e * e;
  if (!options.analyse) return fit;
  fit.structure_jacobian = fit.jacobian;
  if (model.Find(Effect::kProbeGain) >= 0 || model.Find(Effect::kProbeNonlinearity) >= 0) {
    PointsData expected = points;
    for (std::size_t i = 0; i < expected.samples.size(); ++i) expected.samples[i].r_mm += result.residuals_mm[i];
    fit.structure_jacobian = JacobianAt(expected, options, fit);
  }

  std::vector<ParameterDescription> desc =
      internal::BaseParameterDescriptions(result.setup_ids, options.sphere_radius_mm);
  for (const EffectTerm& term : model.terms) {
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      desc.push_back({term.ParamName(i), term.info().quantity, options.sphere_radius_mm});
    }
  }
  const Eigen::Map<const Eigen::VectorXd> res(result.residuals_mm.data(),
                                              static_cast<Eigen::Index>(result.residuals_mm.size()));
  result.analysis = AnalyseFit(fit.jacobian, res, std::move(desc), options.max_std_um);
  return fit;
}

std::vector<Eigen::Vector3d> OffsetsFromCentre(const PointsData& points, const CalibrationOptions& options,
                                               const EffectFit& fit) {
  const std::map<int, std::size_t> setup_index = IndexOfSetups(fit.calibration.setup_ids);
  const CalibrationResult& cal = fit.calibration;
  std::vector<const double*> blocks;
  for (const auto& v : fit.values) blocks.push_back(v.data());
  const ScmsErrorTrig<double> trig = ErrorTrigOf(cal.geometry.data());
  std::vector<Eigen::Vector3d> out;
  out.reserve(points.samples.size());
  for (const Sample& s : points.samples) {
    const auto it = setup_index.find(s.setup);
    if (it == setup_index.end()) {
      throw Error(points.source + ": setup " + std::to_string(s.setup) + " is not one of the calibration's");
    }
    const Eigen::Vector3d p = EffectScmsPoint(cal.geometry.data(), trig, fit.model, blocks.data(),
                                              EffectReading(s.theta_deg, s.phi_deg, s.r_mm, s.t_s),
                                              options.probe_offset_mm);
    out.push_back(p - cal.centers_mm[it->second]);
  }
  return out;
}

std::vector<double> EffectResiduals(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  std::vector<double> out;
  for (const Eigen::Vector3d& v : OffsetsFromCentre(points, options, fit)) out.push_back(v.norm() - options.sphere_radius_mm);
  return out;
}

}  // namespace sph
