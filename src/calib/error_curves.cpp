#include "sph/calib/error_curves.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string_view>

#include <Eigen/Dense>

#include "sph/stats/gum.hpp"
#include "sph/model/units.hpp"
#include "sph/select/residual_structure.hpp"

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

bool SameComponent(const EffectComponent& a, const EffectComponent& b) {
  return a.order == b.order && a.sine == b.sine && a.axis == b.axis;
}

// cos k x or sin k x of each of `components` at `at_deg`, less `mean`.
Eigen::VectorXd BasisOf(const std::vector<EffectComponent>& components, const Eigen::VectorXd& mean, double at_deg) {
  Eigen::VectorXd b(static_cast<Eigen::Index>(components.size()));
  const double x = at_deg * kRadPerDeg;
  for (std::size_t i = 0; i < components.size(); ++i) {
    const EffectComponent& c = components[i];
    b(static_cast<Eigen::Index>(i)) = c.sine ? std::sin(c.order * x) : std::cos(c.order * x);
  }
  return mean.size() == b.size() ? Eigen::VectorXd(b - mean) : b;
}

// The fit of `fit`'s model with term `t` holding its components, then every other component of
// DefaultTerm(searched) that the readings separate: fitted from `fit` with the others at zero; while
// a component of the term has a VIF above max_vif (or none finite), the least separable of those
// added is left out and the model fitted again. No value: a fit did not converge or was not
// analysed. `fit` itself when nothing was left out.
std::optional<EffectFit> FullFit(const PointsData& kept, const CalibrationOptions& options, const EffectFit& fit,
                                 std::size_t t, HarmonicOrders searched, double max_vif) {
  const EffectTerm& term = fit.model.terms[t];
  EffectTerm full = term;
  for (const EffectComponent& s : DefaultTerm(term.effect, searched).components) {
    if (std::none_of(term.components.begin(), term.components.end(),
                     [&](const EffectComponent& f) { return SameComponent(f, s); })) {
      full.components.push_back(s);
    }
  }
  CalibrationOptions analysed = options;
  analysed.analyse = true;
  EffectModel model = fit.model;
  EffectFitStart start = EffectFitStart::From(fit);
  while (full.components.size() > term.components.size()) {
    model.terms[t] = full;
    start.values[t] = fit.values[t];
    start.values[t].resize(full.components.size(), 0.0);
    EffectFit f = FitEffects(kept, analysed, model, start);
    if (!f.calibration.converged || f.calibration.analysis.Empty()) return std::nullopt;
    const Eigen::VectorXd& vif = f.calibration.analysis.vif;
    const int offset = f.TermOffset(t);
    bool separable = true;
    for (int i = 0; i < full.size(); ++i) separable = separable && vif(offset + i) <= max_vif;
    if (separable) return f;
    std::size_t worst = term.components.size();
    for (std::size_t i = worst + 1; i < full.components.size(); ++i) {
      const double v = vif(offset + static_cast<int>(i)), w = vif(offset + static_cast<int>(worst));
      if (!(v <= w)) worst = i;  // NaN counts as the least separable
    }
    full.components.erase(full.components.begin() + static_cast<std::ptrdiff_t>(worst));
  }
  return fit;
}

// The models averaged for a term: each subset S of the components of `full`'s term t within two
// components of those `fit` chose (the chosen, and every one with one or two components added or
// left out; the empty set, no such term, among them), each fitted by the linearised problem at `full` (x_S =
// x - C_:L C_LL^-1 x_L, C_S = C - C_:L C_LL^-1 C_L:) and weighted by exp(-ebic_S / 2), ebic_S = x_L^T
// C_LL^-1 x_L - |L| ln m + SubsetSearchPenalty(searched, |S|), the extended BIC by which the trace
// chooses, less the full model's. The second moment about the chosen values x_c:
// M = sum_S w_S (C_S + (x_S - x_c)(x_S - x_c)^T), internal units, the full term's order. No value
// when the chosen model itself cannot be formed (C_LL not positive definite).
struct Averaged {
  Eigen::MatrixXd moment;
  double chosen_weight = 1.0;
  int models = 1;
};
std::optional<Averaged> AverageModels(const EffectFit& fit, const EffectFit& full, std::size_t t, int searched,
                                      double rows) {
  const std::size_t chosen = fit.model.terms[t].components.size();
  const auto p = static_cast<Eigen::Index>(full.model.terms[t].components.size());
  const Eigen::Index offset = full.TermOffset(t);
  const Eigen::MatrixXd c = full.calibration.analysis.covariance.block(offset, offset, p, p);
  const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(full.values[t].data(), p);
  Eigen::VectorXd x_chosen = Eigen::VectorXd::Zero(p);
  for (std::size_t i = 0; i < chosen; ++i) x_chosen(static_cast<Eigen::Index>(i)) = fit.values[t][i];
  const double log_m = std::log(rows);
  // Each model: which components it holds, its weight's exponent, its values and covariance.
  struct Model {
    std::vector<bool> in;
    double ebic = 0.0;
    Eigen::VectorXd values;
    Eigen::MatrixXd covariance;
  };
  std::vector<Model> models;
  const auto add = [&](std::vector<bool> in) {
    std::vector<Eigen::Index> out;
    for (Eigen::Index i = 0; i < p; ++i) {
      if (!in[static_cast<std::size_t>(i)]) out.push_back(i);
    }
    const auto l = static_cast<Eigen::Index>(out.size());
    Model m{std::move(in), 0.0, x, c};
    if (l > 0) {
      Eigen::MatrixXd c_ll(l, l), c_al(p, l);
      Eigen::VectorXd x_l(l);
      for (Eigen::Index j = 0; j < l; ++j) {
        x_l(j) = x(out[static_cast<std::size_t>(j)]);
        c_al.col(j) = c.col(out[static_cast<std::size_t>(j)]);
        for (Eigen::Index i = 0; i < l; ++i)
          c_ll(i, j) = c(out[static_cast<std::size_t>(i)], out[static_cast<std::size_t>(j)]);
      }
      const Eigen::LLT<Eigen::MatrixXd> llt(c_ll);
      if (llt.info() != Eigen::Success) return;
      const Eigen::VectorXd y = llt.solve(x_l);
      m.values -= c_al * y;
      m.covariance -= c_al * llt.solve(c_al.transpose());
      m.ebic = x_l.dot(y) - static_cast<double>(l) * log_m;
    }
    m.ebic += SubsetSearchPenalty(searched, static_cast<int>(p - l));
    if (m.values.allFinite() && m.covariance.allFinite() && std::isfinite(m.ebic)) models.push_back(std::move(m));
  };
  std::vector<bool> base(static_cast<std::size_t>(p), false);
  for (std::size_t i = 0; i < chosen; ++i) base[i] = true;
  add(base);
  for (std::size_t i = 0; i < base.size(); ++i) {
    std::vector<bool> one = base;
    one[i] = !one[i];
    add(one);
    for (std::size_t j = i + 1; j < base.size(); ++j) {
      std::vector<bool> two = one;
      two[j] = !two[j];
      add(two);
    }
  }
  Averaged a;
  a.moment = Eigen::MatrixXd::Zero(p, p);
  if (models.empty() || models.front().in != base) return std::nullopt;
  double least = std::numeric_limits<double>::infinity();
  for (const Model& m : models) least = std::min(least, m.ebic);
  double total = 0.0;
  for (const Model& m : models) total += std::exp(-0.5 * (m.ebic - least));
  for (const Model& m : models) {
    const double w = std::exp(-0.5 * (m.ebic - least)) / total;
    const Eigen::VectorXd d = m.values - x_chosen;
    a.moment += w * (m.covariance + d * d.transpose());
  }
  a.chosen_weight = std::exp(-0.5 * (models.front().ebic - least)) / total;
  a.models = static_cast<int>(models.size());
  return a;
}

}  // namespace

Eigen::VectorXd ErrorCurve::Basis(double at_deg) const { return BasisOf(components, basis_mean, at_deg); }

Eigen::VectorXd ErrorCurve::BandBasis(double at_deg) const { return BasisOf(band_components, band_basis_mean, at_deg); }

double ErrorCurve::ValueAt(double at_deg) const { return coefficients.dot(Basis(at_deg)); }

double ErrorCurve::U95At(double at_deg) const {
  const Eigen::VectorXd g = BandBasis(at_deg);
  return coverage_factor * std::sqrt(std::max(0.0, g.dot(band_moment * g)));
}

std::vector<ErrorCurve> ErrorCurvesOf(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                      HarmonicOrders searched, double max_vif, double coverage_probability) {
  std::vector<ErrorCurve> curves;
  const ObservabilityReport& rep = fit.calibration.analysis;
  const double k = gum::CoverageFactor(coverage_probability, rep.degrees_of_freedom);
  const PointsData used = WithoutOutliers(points, fit.calibration);
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    const EffectTerm& term = fit.model.terms[t];
    const EffectInfo& info = term.info();
    if (!info.harmonic || term.components.empty()) continue;
    // The models averaged for the band: about those the choice of components could have given.
    const std::optional<EffectFit> full_fit = FullFit(used, options, fit, t, searched, max_vif);
    const int searched_size = static_cast<int>(DefaultTerm(term.effect, searched).components.size());
    std::optional<Averaged> averaged;
    if (full_fit && !rep.Empty()) {
      averaged = AverageModels(fit, *full_fit, t, searched_size, static_cast<double>(used.samples.size()));
    }
    const EffectFit& full = averaged ? *full_fit : fit;
    const EffectTerm& full_term = full.model.terms[t];
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
      // The band's components on this axis and the averaged models' second moment about the chosen
      // values (the chosen components' covariance when no model is averaged).
      c.models_averaged = averaged ? averaged->models : 1;
      c.chosen_weight = averaged ? averaged->chosen_weight : 1.0;
      std::vector<Eigen::Index> band_at;
      for (std::size_t i = 0; i < full_term.components.size(); ++i) {
        if (full_term.components[i].axis != axis) continue;
        c.band_components.push_back(full_term.components[i]);
        c.averaged.push_back(full_term.ParamName(i));
        band_at.push_back(static_cast<Eigen::Index>(i));
      }
      const auto bm = static_cast<Eigen::Index>(band_at.size());
      c.band_moment.resize(bm, bm);
      for (Eigen::Index i = 0; i < bm; ++i) {
        for (Eigen::Index j = 0; j < bm; ++j) {
          c.band_moment(i, j) =
              averaged ? averaged->moment(band_at[static_cast<std::size_t>(i)], band_at[static_cast<std::size_t>(j)]) *
                             per * per
                       : c.covariance(i, j);
        }
      }
      // The bases over the pattern's angles, and their means.
      c.basis_mean = Eigen::VectorXd::Zero(m);
      c.band_basis_mean = Eigen::VectorXd::Zero(bm);
      Eigen::MatrixXd basis(static_cast<Eigen::Index>(angles.size()), m);
      Eigen::MatrixXd band_basis(static_cast<Eigen::Index>(angles.size()), bm);
      for (std::size_t a = 0; a < angles.size(); ++a) {
        basis.row(static_cast<Eigen::Index>(a)) = c.Basis(angles[a]);
        band_basis.row(static_cast<Eigen::Index>(a)) = c.BandBasis(angles[a]);
      }
      c.basis_mean = basis.colwise().mean().transpose();
      c.band_basis_mean = band_basis.colwise().mean().transpose();
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
      const Eigen::VectorXd g = c.BandBasis(c.max_angle_deg) - c.BandBasis(c.min_angle_deg);
      c.pv_u95 = k * std::sqrt(std::max(0.0, g.dot(c.band_moment * g)));
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
