// Calibration with effects: the problem of sph/calib/calibrator.hpp with the effect terms' blocks.
#include "sph/calib/effect_fit.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <utility>

#include "effect_fit_rows.hpp"
#include "fit_problem.hpp"
#include "problem_eval.hpp"
#include "solve_fit.hpp"
#include "sph/core/error.hpp"

namespace sph {

EffectFitStart EffectFitStart::From(const CalibrationResult& calibration) {
  EffectFitStart s;
  s.geometry = calibration.geometry;
  s.centers_mm = calibration.centers_mm;
  return s;
}

EffectFitStart EffectFitStart::From(const EffectFit& fit) {
  EffectFitStart s = From(fit.calibration);
  s.values = fit.values;
  s.form_values = fit.form_values;
  return s;
}

double EffectFit::Bic() const {
  const double m = static_cast<double>(calibration.residuals_mm.size());
  // Residuals of exact data can be zero: no fit is better than rounding (1e-12 mm).
  return m * std::log(std::max(rss_mm2 / m, 1e-24)) - 2.0 * log_reading_slope + n_params * std::log(m);
}

int EffectFit::TermOffset(std::size_t term) const {
  int offset = kNumScmsParams + 3 * static_cast<int>(calibration.centers_mm.size());
  for (std::size_t i = 0; i < term; ++i) offset += model.terms[i].size();
  return offset;
}

int EffectFit::FormOffset(int group) const {
  return TermOffset(model.terms.size()) + group * static_cast<int>(model.form.terms.size());
}

FormModel FormModelOf(const PointsData& points, const std::vector<FormTerm>& terms) {
  FormModel form;
  form.terms = terms;
  std::map<std::string, int> group_of{{"", 0}};  // by PointsHeader::FormKey()
  for (const int id : points.SetupIds()) {
    FormSetup fs;
    const auto [it, is_new] = group_of.emplace(points.header.FormKey(id), form.NumGroups());
    fs.group = it->second;
    if (is_new) {
      form.group_names.push_back("@" + std::to_string(id));
    } else if (fs.group > 0) {
      form.group_names[static_cast<std::size_t>(fs.group)] += "," + std::to_string(id);
    }
    const auto rotation = points.header.mount_rotations.find(id);
    if (rotation != points.header.mount_rotations.end() && rotation->second.known()) {
      fs.rotation = MountRotationMatrix(*rotation->second.rotation_deg);
    }
    form.setups[id] = fs;
  }
  return form;
}

double FormAt(const EffectFit& fit, int setup_id, const Eigen::Vector3d& offset) {
  const FormModel& form = fit.model.form;
  if (form.Empty()) return 0.0;
  const FormSetup& fs = form.SetupOf(setup_id);
  const Eigen::Vector3d body = fs.rotation.transpose() * offset.normalized();
  return FormValue(form.terms, fit.form_values[static_cast<std::size_t>(fs.group)].data(), body);
}

namespace internal {

std::vector<Eigen::Vector3d> CentersFor(const ReadingTable& table, const RowsOfSetup& rows,
                                        const std::vector<int>& fit_ids, const std::vector<Eigen::Vector3d>& centers,
                                        const std::string& source) {
  const std::map<int, std::size_t> index = IndexOfSetups(fit_ids);
  std::vector<Eigen::Vector3d> out;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (rows[k].empty()) continue;
    const auto it = index.find(table.setup_ids[k]);
    if (it == index.end()) {
      throw Error(source + ": setup " + std::to_string(table.setup_ids[k]) + " is not one of the calibration's");
    }
    out.push_back(centers[it->second]);
  }
  return out;
}

EffectFit FitEffectsRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                         const CalibrationOptions& options, const EffectModel& model, const EffectFitStart& start) {
  const std::string& src = points.source;
  CheckFitOptions(points, options);
  EffectFit fit;
  fit.model = model;
  CalibrationResult& result = fit.calibration;
  RowsOfSetup rows = AllRows(table, left_out);
  const std::size_t n_samples = SetupsWithRows(table, rows, &result.setup_ids);
  const std::size_t n_setups = result.setup_ids.size();
  if (start.centers_mm.size() != n_setups) throw Error(src + ": the start needs one centre per setup");
  fit.n_params = kNumScmsParams + 3 * static_cast<int>(n_setups) + model.NumParams() + model.form.NumParams();
  CheckEnoughSamples(src, n_samples, static_cast<std::size_t>(fit.n_params), "");
  std::vector<std::vector<double>> values(model.terms.size());
  for (std::size_t t = 0; t < model.terms.size(); ++t) {
    const auto size = static_cast<std::size_t>(model.terms[t].size());
    if (t < start.values.size() && start.values[t].size() == size) {
      values[t] = start.values[t];
    } else {
      values[t].assign(size, 0.0);
    }
  }
  const SphereFitProblem problem(table, std::move(rows), model, options);
  Eigen::VectorXd x = problem.Pack(start.geometry, start.centers_mm, values, start.form_values);
  const SolvedFit solved = SolveFit(problem, x, options, n_samples, result, src);
  problem.Unpack(x, &result.geometry, &result.centers_mm, &fit.values, &fit.form_values);
  std::vector<double> all(table.size(), 0.0);
  problem.Residuals(x.data(), all.data());
  result.residuals_mm.reserve(n_samples);
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (left_out != nullptr && (*left_out)[i]) continue;
    result.residuals_mm.push_back(all[i]);
    fit.rss_mm2 += all[i] * all[i];
    fit.log_reading_slope += std::log(std::max(std::abs(ReadingSlope(model, fit.values, table.r_mm[i])), 1e-12));
  }
  SetResidualStatistics(result);
  NoteWeightedReadings(points, solved, all, result);
  if (!options.analyse) return fit;

  result.analysis =
      AnalyseSolved(problem, x, solved, solved.Plain() ? fit.rss_mm2 : WeightedRss(problem, solved, all),
                    ParameterDescriptions(result.setup_ids, model, options.sphere_radius_mm), options.max_std_um);
  return fit;
}

namespace {

// The problem of `fit`'s model over the samples of `table` not in `left_out`, and its parameters.
struct ProblemAt {
  SphereFitProblem problem;
  Eigen::VectorXd x;
  ProblemAt(const ReadingTable& table, const std::vector<bool>* left_out, const CalibrationOptions& options,
            const EffectFit& fit, const std::string& source)
      : problem(table, AllRows(table, left_out), fit.model, options) {
    RowsOfSetup rows = AllRows(table, left_out);
    x = problem.Pack(fit.calibration.geometry,
                     CentersFor(table, rows, fit.calibration.setup_ids, fit.calibration.centers_mm, source), fit.values,
                     fit.form_values);
  }
};

}  // namespace

NormalInverse NormalInverseAt(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit) {
  const ProblemAt at(table, nullptr, options, fit, "");
  const double sigma_mm = options.prior_sigma_mm > 0.0 ? options.prior_sigma_mm : fit.calibration.prior_sigma_mm;
  return InformedInverseAt(at.problem, at.x, options, sigma_mm);
}

std::vector<double> ResidualsAt(const ReadingTable& table, const std::vector<bool>* left_out,
                                const CalibrationOptions& options, const EffectFit& fit, const std::string& source) {
  const ProblemAt at(table, left_out, options, fit, source);
  std::vector<double> out(table.size(), 0.0);
  at.problem.Residuals(at.x.data(), out.data());
  return out;
}

}  // namespace internal

Eigen::MatrixXd JacobianAt(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  const internal::ReadingTable table(points);
  const internal::ProblemAt at(table, nullptr, options, fit, points.source);
  return at.problem.DenseJacobian(at.x.data());
}

EffectFit FitEffects(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                     const EffectFitStart& start) {
  return internal::FitEffectsRows(points, internal::ReadingTable(points), nullptr, options, model, start);
}

namespace internal {

std::vector<Eigen::Vector3d> OffsetsFromCentreOf(const PointsData& points, const CalibrationOptions& options,
                                                 const EffectFit& fit, const std::vector<MotionDirection>& approach) {
  const std::map<int, std::size_t> setup_index = internal::IndexOfSetups(fit.calibration.setup_ids);
  const CalibrationResult& cal = fit.calibration;
  std::vector<const double*> blocks;
  for (const auto& v : fit.values) blocks.push_back(v.data());
  const ScmsErrorTrig<double> trig = ErrorTrigOf(cal.geometry.data());
  std::vector<Eigen::Vector3d> out;
  out.reserve(points.samples.size());
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    const auto it = setup_index.find(s.setup);
    if (it == setup_index.end()) {
      throw Error(points.source + ": setup " + std::to_string(s.setup) + " is not one of the calibration's");
    }
    const Eigen::Vector3d& center = cal.centers_mm[it->second];
    const Eigen::Vector3d p =
        EffectScmsPoint(cal.geometry.data(), trig, fit.model, blocks.data(), EffectReading(s, s.t_s, approach[i]),
                        options.probe_offset_mm, nullptr, center.data());
    out.push_back(p - center);
  }
  return out;
}

std::vector<double> EffectResidualsOf(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                      const std::vector<MotionDirection>& approach) {
  std::vector<double> out;
  const std::vector<Eigen::Vector3d> offsets = OffsetsFromCentreOf(points, options, fit, approach);
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    out.push_back(offsets[i].norm() - options.SphereRadiusMm(points.samples[i].setup) -
                  FormAt(fit, points.samples[i].setup, offsets[i]));
  }
  return out;
}

}  // namespace internal

std::vector<Eigen::Vector3d> OffsetsFromCentre(const PointsData& points, const CalibrationOptions& options,
                                               const EffectFit& fit) {
  return internal::OffsetsFromCentreOf(points, options, fit, MotionDirections(points.samples));
}

std::vector<double> EffectResiduals(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  return internal::EffectResidualsOf(points, options, fit, MotionDirections(points.samples));
}

}  // namespace sph
