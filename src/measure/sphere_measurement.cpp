#include "sph/measure/sphere_measurement.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <system_error>

#include <Eigen/Eigenvalues>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/parallel.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;
using internal::ParallelFor;

// The readings' sines and cosines, once for all evaluations.
std::vector<EffectReading> FixedReadings(const std::vector<RawReading>& readings) {
  std::vector<EffectReading> fixed;
  fixed.reserve(readings.size());
  for (const RawReading& r : readings) fixed.emplace_back(r, 0.0);
  return fixed;
}

// The calibration of one evaluation: the applied parameters moved by a vector of the covariance's
// order, and the points they give.
class MovedCalibration {
 public:
  MovedCalibration(const AppliedCalibration& applied, const std::vector<RawReading>& readings)
      : applied_(applied), fixed_(FixedReadings(readings)), cal_(applied.calibration), form_(applied.form.values_mm) {
    points_.resize(fixed_.size());
  }

  // The points under the parameters moved by `delta` (nullptr: none), the readings scaled by 1 + scale.
  const std::vector<Eigen::Vector3d>& Points(const Eigen::VectorXd* delta, double scale = 0.0) {
    cal_.geometry = applied_.calibration.geometry;
    for (std::size_t t = 0; t < cal_.effect_values.size(); ++t)
      cal_.effect_values[t] = applied_.calibration.effect_values[t];
    form_ = applied_.form.values_mm;
    if (delta != nullptr) {
      Eigen::Index k = 0;
      for (double& g : cal_.geometry) g += (*delta)(k++);
      if (applied_.effects_in_covariance) {
        for (auto& block : cal_.effect_values) {
          for (double& v : block) v += (*delta)(k++);
        }
      }
      if (applied_.form_in_covariance) {
        for (double& v : form_) v += (*delta)(k++);
      }
    }
    const internal::CompensationContext ctx(cal_);
    for (std::size_t i = 0; i < fixed_.size(); ++i) {
      EffectReading x = fixed_[i];
      x.r_mm *= 1.0 + scale;
      points_[i] = internal::CompensateWith(cal_, ctx, x);
    }
    if (!applied_.form.Empty()) SubtractForm(applied_.form, form_.data(), points_);
    return points_;
  }

 private:
  const AppliedCalibration& applied_;
  std::vector<EffectReading> fixed_;
  Calibration cal_;
  std::vector<double> form_;
  std::vector<Eigen::Vector3d> points_;
};

// L with L L^T = c: a covariance from a fit can be semidefinite to rounding, so L comes from the
// eigen decomposition with negative eigenvalues set to zero.
Eigen::MatrixXd FactorOf(const Eigen::MatrixXd& c) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(c);
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

}  // namespace

Eigen::Matrix3d CalibrationSphereRotation(const PointsHeader& header, int setup, const std::string& points_name) {
  const std::string which = points_name + ": setup " + std::to_string(setup);
  const auto other = header.sphere_radii_mm.find(setup);
  if (other != header.sphere_radii_mm.end()) {
    throw Error(which + " measured another sphere (" + SphereRadiusKey(setup) + ": " + Format("%g", other->second) +
                " mm), not the calibration sphere whose form the calibration file holds: its form cannot be taken "
                "off these points");
  }
  const auto it = header.mount_rotations.find(setup);
  if (it == header.mount_rotations.end()) return Eigen::Matrix3d::Identity();
  if (!it->second.known()) {
    throw Error(points_name + ": the mount rotation of setup " + std::to_string(setup) +
                " is unknown: the sphere's form cannot be taken off in an orientation nobody measured");
  }
  const Eigen::Matrix3d r = MountRotationMatrix(*it->second.rotation_deg);
  if (!r.allFinite()) {
    throw Error(which + ": " + MountRotationKey(setup) + " " + MountRotationValue(it->second) +
                " gives no rotation (its sines and cosines are not finite numbers)");
  }
  return r;
}

void SubtractForm(const FormCorrection& form, const double* values_mm, std::vector<Eigen::Vector3d>& points_mm) {
  for (Eigen::Vector3d& p : points_mm) {
    const Eigen::Vector3d offset = p - form.center_mm;
    const double dist = offset.norm();
    const Eigen::Vector3d body = form.rotation.transpose() * (offset / dist);
    p = form.center_mm + offset * (1.0 - FormValue(form.terms, values_mm, body) / dist);
  }
}

Eigen::MatrixXd AppliedCalibration::TypeACovariance() const {
  Eigen::MatrixXd a = covariance;
  for (const CalibrationFile::CovarianceInput& in : inputs) a -= in.per_unit * in.per_unit.transpose() * (in.u * in.u);
  return a;
}

AppliedCalibration AppliedCalibration::Of(const CalibrationFile& file, bool with_form) {
  AppliedCalibration a;
  a.calibration = ToCalibration(file);
  a.calibration.covariance.reset();
  if (with_form) {
    a.form.terms = file.form_terms;
    a.form.values_mm = file.form_values_mm;
  }
  const Eigen::MatrixXd c = AppliedCovariance(file);
  if (c.size() == 0) return a;
  auto keep = static_cast<Eigen::Index>(kNumScmsParams);
  if (c.rows() > kNumScmsParams) {
    a.effects_in_covariance = true;
    keep += a.calibration.effects.NumParams();
    a.form_in_covariance = with_form && !file.form_terms.empty();
    if (a.form_in_covariance) keep += static_cast<Eigen::Index>(file.form_terms.size());
  }
  a.covariance = c.topLeftCorner(keep, keep);
  a.names = CalibrationParameterNames(file);
  a.names.resize(static_cast<std::size_t>(keep));
  for (CalibrationFile::CovarianceInput in : file.covariance_inputs) {
    if (in.per_unit.size() != c.rows()) continue;
    in.per_unit = in.per_unit.head(keep).eval();
    a.inputs.push_back(in);
  }
  a.type_a_dof = file.covariance_type_a_dof;
  return a;
}

std::vector<Eigen::Vector3d> ApplyCalibration(const AppliedCalibration& applied,
                                              const std::vector<RawReading>& readings, const Eigen::VectorXd* delta,
                                              double probe_scale) {
  MovedCalibration moved(applied, readings);
  return moved.Points(delta, probe_scale);
}

double MeasuredValue(MeasuredResult which, const std::vector<Eigen::Vector3d>& points, const Sphere& start) {
  SphereFitOptions options;
  options.start = start;
  const LeastSquaresSphere ls = FitSphereLeastSquares(points, options);
  if (!ls.sphere.ok) return std::numeric_limits<double>::quiet_NaN();
  switch (which) {
    case MeasuredResult::kRadius:
      return ls.sphere.radius;
    case MeasuredResult::kSphericityLs:
      return RadialPeakToValley(points, ls.sphere.center);
    case MeasuredResult::kSphericityMz:
      return FitSphereMinimumZone(points, ls.sphere.center).width;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::array<ResultSensitivity, 3> SensitivitiesOf(const std::vector<RawReading>& readings,
                                                 const AppliedCalibration& applied, const SphereEvaluation& nominal) {
  constexpr std::array<MeasuredResult, 3> kAll{MeasuredResult::kRadius, MeasuredResult::kSphericityLs,
                                               MeasuredResult::kSphericityMz};
  constexpr double kScaleStep = 1e-5;  // of the probe readings: 0.05 um on 5 mm
  MovedCalibration moved(applied, readings);
  const Eigen::Index n = applied.covariance.rows();
  std::array<ResultSensitivity, 3> out;
  for (ResultSensitivity& r : out) r.per_parameter = Eigen::VectorXd::Zero(n);
  auto values = [&](const Eigen::VectorXd* delta, double scale) {
    const std::vector<Eigen::Vector3d>& points = moved.Points(delta, scale);
    std::array<double, 3> v{};
    for (std::size_t k = 0; k < 3; ++k) v[k] = MeasuredValue(kAll[k], points, nominal.ls.sphere);
    return v;
  };
  for (Eigen::Index i = 0; i < n; ++i) {
    const double h = 0.1 * std::sqrt(std::max(applied.covariance(i, i), 0.0));
    if (!(h > 0.0)) continue;
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(n);
    delta(i) = h;
    const std::array<double, 3> plus = values(&delta, 0.0);
    delta(i) = -h;
    const std::array<double, 3> minus = values(&delta, 0.0);
    for (std::size_t k = 0; k < 3; ++k) out[k].per_parameter(i) = (plus[k] - minus[k]) / (2.0 * h);
  }
  const std::array<double, 3> plus = values(nullptr, kScaleStep), minus = values(nullptr, -kScaleStep);
  for (std::size_t k = 0; k < 3; ++k) out[k].per_probe_scale = (plus[k] - minus[k]) / (2.0 * kScaleStep);
  return out;
}

gum::UncertaintyStatement MeasurementBudget(const std::string& type_a_name, double type_a_u, double type_a_dof,
                                            const ResultSensitivity& c, const AppliedCalibration& applied,
                                            const gum::CoverageSpec& coverage) {
  using gum::EvaluationType;
  std::vector<gum::BudgetInput> inputs;
  inputs.push_back({type_a_name, EvaluationType::kA, type_a_u, 1.0, type_a_dof, "", "this measurement"});
  const Eigen::VectorXd& s = c.per_parameter;
  if (applied.covariance.size() > 0 && s.size() == applied.covariance.rows()) {
    if (applied.inputs.empty()) {
      inputs.push_back({"calibration (its covariance)", EvaluationType::kB,
                        std::sqrt(std::max(0.0, s.dot(applied.covariance * s))), 1.0, gum::kInfiniteDof, "",
                        "the calibration file does not say what its covariance holds"});
    } else {
      inputs.push_back({"calibration: fit (scatter of its points)", EvaluationType::kA,
                        std::sqrt(std::max(0.0, s.dot(applied.TypeACovariance() * s))), 1.0, applied.type_a_dof, "",
                        "the calibration's Type A covariance"});
      for (const CalibrationFile::CovarianceInput& in : applied.inputs) {
        const bool scale = in.input == kProbeScaleInput;
        inputs.push_back(
            {"calibration: " + in.input, EvaluationType::kB, in.u,
             s.dot(in.per_unit) + (scale ? c.per_probe_scale : 0.0), gum::kInfiniteDof, in.unit,
             scale ? "through the calibration and this measurement's readings" : "through the calibration"});
      }
    }
  }
  return gum::Combine(std::move(inputs), coverage);
}

gum::PropagationResult CheckByMonteCarlo(MeasuredResult which, const std::vector<RawReading>& readings,
                                         const AppliedCalibration& applied, const SphereEvaluation& nominal,
                                         double type_a_u, double type_a_dof, const gum::PropagationOptions& options) {
  if (applied.covariance.size() == 0) throw std::invalid_argument("the calibration has no covariance to propagate");
  const Eigen::MatrixXd l = FactorOf(applied.inputs.empty() ? applied.covariance : applied.TypeACovariance());
  const Eigen::Index n = l.rows();
  std::vector<gum::Distribution> inputs(static_cast<std::size_t>(n), gum::Distribution::Gaussian(0.0, 1.0));
  for (const CalibrationFile::CovarianceInput& in : applied.inputs)
    inputs.push_back(gum::Distribution::Gaussian(0.0, in.u));
  if (std::isfinite(type_a_dof) && type_a_dof > 2.0) {
    inputs.push_back(
        gum::Distribution::StudentT(0.0, type_a_u * std::sqrt((type_a_dof - 2.0) / type_a_dof), type_a_dof));
  } else {
    inputs.push_back(gum::Distribution::Gaussian(0.0, type_a_u));
  }
  MovedCalibration moved(applied, readings);
  Eigen::VectorXd z(n), delta(n);
  auto model = [&](const std::vector<double>& x) {
    for (Eigen::Index i = 0; i < n; ++i) z(i) = x[static_cast<std::size_t>(i)];
    delta = l * z;
    double scale = 0.0;
    for (std::size_t j = 0; j < applied.inputs.size(); ++j) {
      const double xj = x[static_cast<std::size_t>(n) + j];
      delta += applied.inputs[j].per_unit * xj;
      if (applied.inputs[j].input == kProbeScaleInput) scale += xj;
    }
    return MeasuredValue(which, moved.Points(&delta, scale), nominal.ls.sphere) + x.back();
  };
  return gum::PropagateDistributions(model, inputs, options);
}

namespace {

// Why points within reach determine no sphere, in words: they are one point, or lie on one plane
// or line.
std::string WhyNoSphere(const std::vector<Eigen::Vector3d>& points_mm) {
  for (const Eigen::Vector3d& p : points_mm) {
    if (p != points_mm[0]) return "the points determine no sphere (they lie on one plane or line)";
  }
  return "the " + std::to_string(points_mm.size()) + " points are all one point (" +
         Format("%.17g %.17g %.17g", points_mm[0].x(), points_mm[0].y(), points_mm[0].z()) + " mm)";
}

}  // namespace

SphereEvaluation EvaluateSphere(const std::vector<Eigen::Vector3d>& points_mm, const std::string& source,
                                const SphereEvaluationOptions& options) {
  SphereEvaluation ev;
  ev.n_points = static_cast<int>(points_mm.size());
  if (points_mm.size() < 4) {
    throw Error(source + ": " + std::to_string(points_mm.size()) +
                " points are too few to determine a sphere (at least 4)");
  }
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    const Eigen::Vector3d& p = points_mm[i];
    const std::string which = source + ": point " + std::to_string(i + 1) + " of " + std::to_string(points_mm.size()) +
                              " (" + Format("%g %g %g", p.x(), p.y(), p.z()) + " mm)";
    if (!p.allFinite()) throw Error(which + " is not a finite point: no sphere is fitted through it");
    if (!(p.lpNorm<Eigen::Infinity>() <= kMaxPointCoordinateMm)) {
      throw Error(which + " lies beyond " + Format("%g", kMaxPointCoordinateMm) +
                  " mm from the origin, which no measuring machine reaches: are the coordinates in mm?");
    }
  }
  ev.ls = FitSphereLeastSquares(points_mm);
  if (!ev.ls.sphere.ok) throw Error(source + ": " + WhyNoSphere(points_mm));
  ev.residuals_mm = RadialResiduals(points_mm, ev.ls.sphere.center, ev.ls.sphere.radius);
  ev.sphericity_ls_mm = PeakToValley(ev.residuals_mm);
  ev.coverage = CoverageOf(points_mm, ev.ls.sphere.center);
  ev.mz = FitSphereMinimumZone(points_mm, ev.ls.sphere.center);
  if (ev.mz.ok && (ev.coverage.cap_half_angle_deg <= options.multi_start_cap_deg ||
                   ev.mz.MaxDecreaseWithin(ev.mz.near_radius) > options.mz_slack_mm)) {
    ev.mz = FitSphereMinimumZoneMultiStart(points_mm, ev.ls.sphere.center);
  }
  ev.radius_dilution = ev.ls.RadiusDilution();
  ev.center_dilution = ev.ls.CenterDilution();
  if (ev.n_points > 4) {
    const double s2 = ev.ls.rms * ev.ls.rms * ev.n_points / (ev.n_points - 4);
    ev.radius_fit_std_mm = std::sqrt(s2 * ev.ls.normal_inverse(3, 3));
    ev.center_fit_std_mm = (s2 * ev.ls.normal_inverse.diagonal().head<3>()).cwiseSqrt();
  }

  if (std::max(ev.radius_dilution, ev.center_dilution) > options.max_dilution) {
    ev.poorly_determined = true;
    ev.warnings.push_back(Format(
        "ill-posed for the coverage: seen from the centre, the points lie within %.0f deg of their mean direction, so "
        "they determine "
        "the radius %.3g times and the centre %.3g times worse than the same number of points over the whole sphere "
        "(limit %g); radius, centre and both sphericities are poorly determined: measure a larger part of the sphere",
        ev.coverage.cap_half_angle_deg, ev.radius_dilution, ev.center_dilution, options.max_dilution));
  }
  if (ev.n_points <= 5) {
    ev.warnings.push_back(
        Format("only %d points: a sphere has 4 parameters and a minimum zone 5 contact points, so the sphericity says "
               "little about the form",
               ev.n_points));
  }
  if (!ev.ls.converged) ev.warnings.push_back("the least-squares fit did not converge");
  if (!ev.mz.ok || !ev.mz.converged) ev.warnings.push_back("the minimum-zone search did not converge");
  if (ev.mz.ok && !ev.mz.starts.empty() && !ev.mz.StartsAgree()) {
    ev.warnings.push_back(Format(
        "the minimum zone has several local minima for this coverage: searched from %zu starts, it reached widths "
        "from %.4f to %.4f um with centres up to %.4g um apart; the narrowest is reported (sphericity_mz_um)",
        ev.mz.starts.size(), ev.mz.width * kUmPerMm, (ev.mz.width + ev.mz.StartWidthSpread()) * kUmPerMm,
        ev.mz.StartCenterSpread() * kUmPerMm));
  }
  return ev;
}

CalibrationUncertainty PropagateCalibrationUncertainty(const std::vector<RawReading>& readings, const Calibration& cal,
                                                       const SphereEvaluation& nominal,
                                                       const UncertaintyOptions& options) {
  if (!cal.covariance) throw std::invalid_argument("the calibration has no covariance to propagate");
  AppliedCalibration applied;
  applied.calibration = cal;
  applied.covariance = *cal.covariance;
  return PropagateCalibrationUncertainty(readings, applied, nominal, options);
}

CalibrationUncertainty PropagateCalibrationUncertainty(const std::vector<RawReading>& readings,
                                                       const AppliedCalibration& applied,
                                                       const SphereEvaluation& nominal,
                                                       const UncertaintyOptions& options) {
  if (applied.covariance.size() == 0) throw std::invalid_argument("the calibration has no covariance to propagate");
  if (options.samples < 2) throw std::invalid_argument("at least 2 samples are needed for a standard deviation");
  if (readings.size() != nominal.residuals_mm.size()) {
    throw std::invalid_argument("the readings are not those of the nominal evaluation");
  }
  CalibrationUncertainty u;
  u.samples = options.samples;
  u.seed = options.seed;

  // x_s = L z, z ~ N(0, I), L L^T = Sigma (FactorOf). When the file says what Sigma holds, its
  // Type A part is drawn so and each Type B input on its own, x_s = L_A z + sum_j s_j x_j, so that
  // the probe scale also scales these readings (CheckByMonteCarlo() draws the same way). The draws
  // come first, in order, so that the result depends on the seed only, not on the threads.
  const Eigen::MatrixXd l = FactorOf(applied.inputs.empty() ? applied.covariance : applied.TypeACovariance());
  Random rng(options.seed);
  std::vector<Eigen::VectorXd> draws(static_cast<std::size_t>(options.samples));
  std::vector<double> scales(draws.size(), 0.0);
  for (std::size_t s = 0; s < draws.size(); ++s) {
    Eigen::VectorXd z(l.cols());
    for (Eigen::Index k = 0; k < z.size(); ++k) z(k) = rng.Normal();
    draws[s] = l * z;
    for (const CalibrationFile::CovarianceInput& in : applied.inputs) {
      const double x = in.u * rng.Normal();
      draws[s] += in.per_unit * x;
      if (in.input == kProbeScaleInput) scales[s] += x;
    }
  }

  struct Outcome {
    bool ok = false;
    double radius = 0.0, pv_ls = 0.0, pv_mz = 0.0, form = 0.0;
    Eigen::Vector3d center = Eigen::Vector3d::Zero();
  };
  std::vector<Outcome> outcomes(draws.size());
  std::size_t done = 0;
  std::mutex progress_mutex;
  SphereFitOptions ls_options;
  ls_options.start = nominal.ls.sphere;  // each draw's sphere is near the nominal one
  ParallelFor(draws.size(), options.threads, [&] {
    return [&, moved = MovedCalibration(applied, readings)](std::size_t s) mutable {
      const std::vector<Eigen::Vector3d>& points = moved.Points(&draws[s], scales[s]);
      const LeastSquaresSphere ls = FitSphereLeastSquares(points, ls_options);
      Outcome& o = outcomes[s];
      if (ls.sphere.ok) {  // a draw that destroys the sphere says nothing about this one
        // Peak-to-valley of the residuals and of their change from the nominal evaluation.
        double lo = std::numeric_limits<double>::infinity(), hi = -lo, change_lo = lo, change_hi = -lo;
        for (std::size_t i = 0; i < points.size(); ++i) {
          const double e = (points[i] - ls.sphere.center).norm() - ls.sphere.radius;
          const double change = e - nominal.residuals_mm[i];
          lo = std::min(lo, e);
          hi = std::max(hi, e);
          change_lo = std::min(change_lo, change);
          change_hi = std::max(change_hi, change);
        }
        o = {true,
             ls.sphere.radius,
             hi - lo,
             FitSphereMinimumZone(points, ls.sphere.center).width,
             change_hi - change_lo,
             ls.sphere.center};
      }
      const std::lock_guard<std::mutex> lock(progress_mutex);  // counted and told in order
      ++done;
      if (options.progress) options.progress(static_cast<int>(done), options.samples);
    };
  });

  std::vector<double> radius, pv_ls, pv_mz, form;
  std::vector<Eigen::Vector3d> center;
  for (const Outcome& o : outcomes) {
    if (!o.ok) continue;
    radius.push_back(o.radius);
    center.push_back(o.center);
    pv_ls.push_back(o.pv_ls);
    pv_mz.push_back(o.pv_mz);
    form.push_back(o.form);
  }
  if (radius.size() < 2) throw std::invalid_argument("no calibration draw gave a sphere");
  u.radius_std_mm = gum::SampleStd(radius);
  for (int k = 0; k < 3; ++k) {
    std::vector<double> ck;
    for (const auto& c : center) ck.push_back(c(k));
    u.center_std_mm(k) = gum::SampleStd(ck);
  }
  u.sphericity_ls_std_mm = gum::SampleStd(pv_ls);
  u.sphericity_mz_std_mm = gum::SampleStd(pv_mz);
  std::sort(form.begin(), form.end());
  const auto k95 = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(form.size()))) - 1;
  u.calibration_form_p95_mm = form[k95];
  u.form_exceeds_calibration = nominal.sphericity_ls_mm > u.calibration_form_p95_mm;
  return u;
}

}  // namespace sph
