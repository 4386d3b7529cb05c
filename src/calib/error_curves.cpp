#include "sph/calib/error_curves.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string_view>

#include <Eigen/Dense>

#include "sph/stats/gum.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

constexpr double kSameDeg = 1e-6;  // angles closer than this are one angle of the pattern

// The distinct angles of the readings of `variable`, in [0, 360), ascending.
std::vector<double> DistinctAnglesDeg(const PointsData& points, std::string_view variable) {
  std::vector<double> a;
  a.reserve(points.samples.size());
  for (const Sample& s : points.samples) {
    double x = std::fmod(variable == "phi" ? s.phi_deg : s.theta_deg, 360.0);
    if (x < 0.0) x += 360.0;
    if (x >= 360.0 - kSameDeg) x = 0.0;
    a.push_back(x);
  }
  std::sort(a.begin(), a.end());
  std::vector<double> out;
  for (double x : a) {
    if (out.empty() || x - out.back() > kSameDeg) out.push_back(x);
  }
  return out;
}

// The ISO 230 symbol of axis `axis` of an effect: "EXC, EYC (radial ...)" gives EXC or EYC.
std::string IsoSymbol(const EffectInfo& info, int axis) {
  std::string s = info.iso_name;
  s = s.substr(0, s.find(" ("));
  if (info.axes == 2) {
    const std::size_t comma = s.find(", ");
    s = axis == 0 ? s.substr(0, comma) : s.substr(comma + 2);
  }
  return s;
}

std::string Convention(const EffectInfo& info, Effect e, int axis) {
  switch (e) {
    case Effect::kThetaEncoder:
    case Effect::kPhiEncoder:
      return "ISO 230-2 positional deviation, actual minus indicated; its range (max - min) over the measured range";
    case Effect::kThetaAxialMotion:
    case Effect::kPhiAxialMotion:
      return "ISO 230-7 axial error motion along the axis; its error motion value (peak to valley) over the range";
    default:
      break;
  }
  const std::string direction =
      info.quantity == Quantity::kAngle ? (axis == 0 ? "about x" : "about y") : (axis == 0 ? "along x" : "along y");
  const std::string kind = info.quantity == Quantity::kAngle ? "tilt" : "radial";
  return "ISO 230-7 " + kind + " error motion " + direction + " of the axis' frame (a fixed sensitive direction); " +
         "its error motion value (peak to valley) over the range";
}

double Mod360(double x) {
  x = std::fmod(x, 360.0);
  return x < 0.0 ? x + 360.0 : x;
}

}  // namespace

Eigen::VectorXd ErrorCurve::Basis(double at_deg) const {
  Eigen::VectorXd b(static_cast<Eigen::Index>(components.size()));
  const double x = at_deg * kRadPerDeg;
  for (std::size_t i = 0; i < components.size(); ++i) {
    const EffectComponent& c = components[i];
    b(static_cast<Eigen::Index>(i)) = c.sine ? std::sin(c.order * x) : std::cos(c.order * x);
  }
  return b - basis_mean;
}

double ErrorCurve::ValueAt(double at_deg) const { return coefficients.dot(Basis(at_deg)); }

double ErrorCurve::U95At(double at_deg) const {
  const Eigen::VectorXd g = Basis(at_deg);
  return coverage_factor * std::sqrt(std::max(0.0, g.dot(covariance * g)));
}

std::vector<ErrorCurve> ErrorCurvesOf(const PointsData& points, const EffectFit& fit, HarmonicOrders searched,
                                      double coverage_probability) {
  std::vector<ErrorCurve> curves;
  const ObservabilityReport& rep = fit.calibration.analysis;
  const double k = gum::CoverageFactor(coverage_probability, rep.degrees_of_freedom);
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    const EffectTerm& term = fit.model.terms[t];
    const EffectInfo& info = term.info();
    if (!info.harmonic || term.components.empty()) continue;
    const double per = info.quantity == Quantity::kAngle ? 1.0 / kRadPerArcsec : kUmPerMm;
    const std::vector<double> angles = DistinctAnglesDeg(points, info.variable);
    if (angles.empty()) continue;
    // The measured range: the arc left by the largest gap between neighbouring angles.
    std::size_t after_gap = 0;
    double gap = angles.front() + 360.0 - angles.back();
    for (std::size_t i = 1; i < angles.size(); ++i) {
      if (angles[i] - angles[i - 1] > gap) {
        gap = angles[i] - angles[i - 1];
        after_gap = i;
      }
    }
    const EffectTerm all = DefaultTerm(term.effect, searched);
    for (int axis = 0; axis < info.axes; ++axis) {
      ErrorCurve c;
      c.effect = term.effect;
      c.axis = axis;
      c.name = std::string(info.id) + (info.axes == 2 ? (axis == 0 ? ".x" : ".y") : "");
      c.iso_name = IsoSymbol(info, axis);
      c.variable = info.variable;
      c.unit = info.quantity == Quantity::kAngle ? "arcsec" : "um";
      c.encoder = term.effect == Effect::kThetaEncoder || term.effect == Effect::kPhiEncoder;
      c.convention = Convention(info, term.effect, axis);
      c.coverage_probability = coverage_probability;
      c.coverage_factor = k;
      const double n = static_cast<double>(angles.size());
      c.full_turn = angles.size() > 2 && gap <= 2.0 * 360.0 / n;
      c.range_lo_deg = c.full_turn ? 0.0 : angles[after_gap];
      c.range_hi_deg = c.full_turn ? 360.0 : c.range_lo_deg + 360.0 - gap;
      // The components on this axis, with their values and covariance.
      std::vector<int> cols;
      for (std::size_t i = 0; i < term.components.size(); ++i) {
        if (term.components[i].axis != axis) continue;
        c.components.push_back(term.components[i]);
        c.fitted.push_back(term.ParamName(i));
        cols.push_back(fit.TermOffset(t) + static_cast<int>(i));
      }
      if (cols.empty()) continue;
      const auto m = static_cast<Eigen::Index>(cols.size());
      c.coefficients.resize(m);
      c.covariance.resize(m, m);
      for (Eigen::Index i = 0; i < m; ++i) {
        const std::size_t comp = static_cast<std::size_t>(cols[static_cast<std::size_t>(i)] - fit.TermOffset(t));
        c.coefficients(i) = fit.values[t][comp] * per;
        for (Eigen::Index j = 0; j < m; ++j) {
          c.covariance(i, j) =
              rep.Empty()
                  ? std::numeric_limits<double>::quiet_NaN()
                  : rep.covariance(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]) * per * per;
        }
      }
      // The basis over the pattern's angles, and its mean.
      c.basis_mean = Eigen::VectorXd::Zero(m);
      Eigen::MatrixXd basis(static_cast<Eigen::Index>(angles.size()), m);
      for (std::size_t a = 0; a < angles.size(); ++a) basis.row(static_cast<Eigen::Index>(a)) = c.Basis(angles[a]);
      c.basis_mean = basis.colwise().mean().transpose();
      basis.rowwise() -= c.basis_mean.transpose();
      // The table: the angles from the range's start, thinned to an even step when too many.
      std::vector<double> ordered;
      for (std::size_t a = 0; a < angles.size(); ++a) ordered.push_back(angles[(after_gap + a) % angles.size()]);
      if (c.full_turn) ordered = angles;
      if (ordered.size() > static_cast<std::size_t>(kMaxCurveTableAngles)) {
        ordered.clear();
        const double span = c.range_hi_deg - c.range_lo_deg;
        const int steps = c.full_turn ? kMaxCurveTableAngles : kMaxCurveTableAngles - 1;
        for (int s = 0; s < kMaxCurveTableAngles; ++s) ordered.push_back(Mod360(c.range_lo_deg + span * s / steps));
      }
      for (double a : ordered) {
        c.angle_deg.push_back(a);
        c.value.push_back(c.ValueAt(a));
        c.u95.push_back(c.U95At(a));
      }
      // Peak to valley on a fine grid over the range (0.1 deg or 3600 steps).
      const double span = c.range_hi_deg - c.range_lo_deg;
      const int steps = std::max(1, static_cast<int>(std::ceil(span / 0.1)));
      double hi = -std::numeric_limits<double>::infinity(), lo = std::numeric_limits<double>::infinity();
      for (int s = 0; s <= steps; ++s) {
        const double a = Mod360(c.range_lo_deg + span * s / steps);
        const double v = c.ValueAt(a);
        if (v > hi) {
          hi = v;
          c.max_angle_deg = a;
        }
        if (v < lo) {
          lo = v;
          c.min_angle_deg = a;
        }
      }
      c.pv = hi - lo;
      const Eigen::VectorXd g = c.Basis(c.max_angle_deg) - c.Basis(c.min_angle_deg);
      c.pv_u95 = k * std::sqrt(std::max(0.0, g.dot(c.covariance * g)));
      // The components searched but not fitted, and how much of each the fitted ones represent.
      const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(basis);
      for (std::size_t i = 0; i < all.components.size(); ++i) {
        const EffectComponent& s = all.components[i];
        if (s.axis != axis) continue;
        const bool kept = std::any_of(c.components.begin(), c.components.end(),
                                      [&](const EffectComponent& f) { return f.order == s.order && f.sine == s.sine; });
        if (kept) continue;
        Eigen::VectorXd f(static_cast<Eigen::Index>(angles.size()));
        for (std::size_t a = 0; a < angles.size(); ++a) {
          const double x = angles[a] * kRadPerDeg;
          f(static_cast<Eigen::Index>(a)) = s.sine ? std::sin(s.order * x) : std::cos(s.order * x);
        }
        f.array() -= f.mean();
        const double ff = f.squaredNorm();
        double represented = 0.0;
        if (ff > 1e-12 * n) represented = 1.0 - (f - basis * qr.solve(f)).squaredNorm() / ff;
        c.left_out.push_back({all.ParamName(i), std::clamp(represented, 0.0, 1.0)});
      }
      curves.push_back(std::move(c));
    }
  }
  return curves;
}

}  // namespace sph
