#include "sph/io/calibration_comparison.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Whether two stored numbers are the same to the rounding of a file.
bool Same(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)}); }

// One calibration file as the comparison sees it: every parameter's name, value, unit, its
// covariance where the file states one (NaN where it does not) and its itemised Type B inputs.
struct Side {
  const CalibrationFile* file = nullptr;
  std::vector<std::string> names;
  Eigen::VectorXd values;      // internal units
  Eigen::VectorXd per_report;  // internal units per report unit
  std::vector<std::string> units;
  Eigen::MatrixXd covariance;                                   // internal units, NaN where not stated
  std::vector<const CalibrationFile::CovarianceInput*> inputs;  // those of the full size

  int Find(const std::string& name) const {
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  }
  // g^T C g over the parameters g touches; NaN when the file states no covariance of one of them.
  double Variance(const Eigen::VectorXd& g) const {
    double v = 0.0;
    for (Eigen::Index p = 0; p < g.size(); ++p) {
      if (g(p) == 0.0) continue;
      for (Eigen::Index q = 0; q < g.size(); ++q) {
        if (g(q) != 0.0) v += g(p) * covariance(p, q) * g(q);
      }
    }
    return v;
  }
  const CalibrationFile::CovarianceInput* Input(const std::string& name) const {
    for (const CalibrationFile::CovarianceInput* in : inputs) {
      if (in->input == name) return in;
    }
    return nullptr;
  }
};

Side SideOf(const CalibrationFile& f) {
  Side s;
  s.file = &f;
  s.names = CalibrationParameterNames(f);
  const auto n = static_cast<Eigen::Index>(s.names.size());
  s.values.resize(n);
  s.per_report.resize(n);
  Eigen::Index k = 0;
  for (int p = 0; p < kNumScmsParams; ++p, ++k) {
    s.values(k) = f.geometry[static_cast<std::size_t>(p)];
    s.per_report(k) = 1.0 / ReportUnitsOf(p).to_fine;
    s.units.emplace_back(ReportUnitsOf(p).fine);
  }
  for (std::size_t t = 0; t < f.effects.terms.size(); ++t) {
    const bool angle = f.effects.terms[t].info().quantity == Quantity::kAngle;
    for (double v : f.effect_values[t]) {
      s.values(k) = v;
      s.per_report(k) = angle ? kRadPerArcsec : kMmPerUm;
      s.units.emplace_back(angle ? "arcsec" : "um");
      ++k;
    }
  }
  for (double v : f.form_values_mm) {
    s.values(k) = v;
    s.per_report(k) = kMmPerUm;
    s.units.emplace_back("um");
    ++k;
  }
  s.covariance = Eigen::MatrixXd::Constant(n, n, kNaN);
  const Eigen::MatrixXd c = AppliedCovariance(f);
  s.covariance.topLeftCorner(c.rows(), c.cols()) = c;
  if (c.rows() < n && !f.form_std_mm.empty()) {  // the form's own uncertainties, each term alone
    const auto first = static_cast<Eigen::Index>(n - static_cast<Eigen::Index>(f.form_terms.size()));
    for (Eigen::Index p = first; p < n; ++p) {
      for (Eigen::Index q = first; q < n; ++q) {
        const double u = f.form_std_mm[static_cast<std::size_t>(p - first)];
        s.covariance(p, q) = p == q ? u * u : 0.0;
      }
    }
  }
  for (const CalibrationFile::CovarianceInput& in : f.covariance_inputs) {
    if (in.per_unit.size() == c.rows()) s.inputs.push_back(&in);
  }
  return s;
}

// The contribution s_j u_j of an input to g's quantity: NaN when the input is not itemised over
// every parameter g touches.
double Share(const CalibrationFile::CovarianceInput& in, const Eigen::VectorXd& g) {
  double x = 0.0;
  for (Eigen::Index p = 0; p < g.size(); ++p) {
    if (g(p) == 0.0) continue;
    if (p >= in.per_unit.size()) return kNaN;
    x += g(p) * in.per_unit(p) * in.u;
  }
  return x;
}

// The inputs both take from one source: their names; and what the comparison says of the others.
std::vector<std::string> SharedInputs(const Side& prev, const Side& now, std::vector<std::string>& notes) {
  std::vector<std::string> shared;
  for (const std::string name : {"R0 (certificate)", "probe scale"}) {
    const CalibrationFile::CovarianceInput* a = prev.Input(name);
    const CalibrationFile::CovarianceInput* b = now.Input(name);
    if (a == nullptr || b == nullptr) {
      if (a != nullptr || b != nullptr) {
        notes.push_back(std::string(name) + ": not itemised in the " + (a == nullptr ? "previous" : "current") +
                        " calibration's covariance: counted independent");
      }
      continue;
    }
    if (a->u == 0.0 && b->u == 0.0) continue;  // not stated in either: no contribution
    if (std::string(name) == "R0 (certificate)") {
      const std::optional<double>& ra = prev.file->sphere_radius_mm;
      const std::optional<double>& rb = now.file->sphere_radius_mm;
      const double tolerance_mm = kComparisonCoverageFactor * std::hypot(a->u, b->u) * kMmPerUm + 1e-9;
      if (!ra || !rb || std::abs(*ra - *rb) > tolerance_mm) {
        notes.push_back("R0 (certificate): the calibrations' R0 differ (" +
                        (ra ? Format("%.9g", *ra) : std::string("not stated")) + " mm, " +
                        (rb ? Format("%.9g", *rb) : std::string("not stated")) +
                        " mm): another sphere or certificate, counted independent");
        continue;
      }
    }
    shared.emplace_back(name);
  }
  notes.push_back("counted independent: the fits' scatter (Type A), the sphere's temperature, the priors");
  return shared;
}

// Why a parameter of an effect both hold cannot be compared value for value, or empty.
std::string NotComparable(const std::string& parameter, const CalibrationFile& prev, const CalibrationFile& now) {
  const std::string id = parameter.substr(0, parameter.find('.'));
  if (id == "probe_gain" || id == "probe_nonlinearity") {
    const EffectReference &a = prev.effects.reference, &b = now.effects.reference;
    if (!Same(a.r_ref_mm, b.r_ref_mm) || !Same(a.r_half_range_mm, b.r_half_range_mm)) {
      return Format(
          "not compared: the probe terms are normalised by other probe readings (r_ref %.6g mm, r_half %.6g mm "
          "before, %.6g mm, %.6g mm now); give the probe's range (probe_range_mm) in both",
          a.r_ref_mm, a.r_half_range_mm, b.r_ref_mm, b.r_half_range_mm);
    }
  }
  if (id == "phi_wobble" && !Same(prev.effects.phi_wobble_pivot_mm, now.effects.phi_wobble_pivot_mm)) {
    return Format("not compared: the Phi axis tilts about another pivot (%.6g mm before, %.6g mm now)",
                  prev.effects.phi_wobble_pivot_mm, now.effects.phi_wobble_pivot_mm);
  }
  return "";
}

// The form's RMS over the sphere [mm] and its gradient in the side's parameters; nullopt without a form.
std::optional<std::pair<double, Eigen::VectorXd>> FormRmsOf(const Side& s) {
  const CalibrationFile& f = *s.file;
  if (f.form_terms.empty()) return std::nullopt;
  const double rms = FormRms(f.form_terms, f.form_values_mm);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(s.values.size());
  const Eigen::Index first = s.values.size() - static_cast<Eigen::Index>(f.form_terms.size());
  for (std::size_t k = 0; k < f.form_terms.size(); ++k) {
    const double w = 1.0 / (2.0 * f.form_terms[k].l + 1.0);
    g(first + static_cast<Eigen::Index>(k)) = rms > 0.0 ? f.form_values_mm[k] * w / rms : 0.0;
  }
  return std::make_pair(rms, g);
}

Eigen::VectorXd Unit(const Side& s, int i) {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(s.values.size());
  g(i) = 1.0;
  return g;
}

// Fills in the difference, U and En of a quantity both hold: values and gradients in internal
// units, `per_report` internal units per report unit.
void Difference(ComparedParameter& c, const Side& prev, const Side& now, double v_prev, const Eigen::VectorXd& g_prev,
                double v_now, const Eigen::VectorXd& g_now, double per_report, const std::vector<std::string>& shared,
                double k) {
  c.found = ComparedParameter::Found::kBoth;
  c.previous = v_prev / per_report;
  c.now = v_now / per_report;
  c.difference = c.now - c.previous;
  double var = prev.Variance(g_prev) + now.Variance(g_now);
  for (const std::string& name : shared) {
    const double correlated = Share(*now.Input(name), g_now) * Share(*prev.Input(name), g_prev);
    if (std::isfinite(correlated)) var -= 2.0 * correlated;  // else not itemised: independent
  }
  if (!std::isfinite(var)) {
    c.note = "no U: a calibration file states no covariance of it";
    return;
  }
  c.U = k * std::sqrt(std::max(var, 0.0)) / per_report;
  if (c.U > 0.0) c.En = c.difference / c.U;
}

// A quantity only one calibration holds: its value and U.
ComparedParameter OneSide(const std::string& parameter, const std::string& unit, const Side& s, double value,
                          const Eigen::VectorXd& g, double per_report, ComparedParameter::Found found, double k) {
  ComparedParameter c;
  c.parameter = parameter;
  c.unit = unit;
  c.found = found;
  (found == ComparedParameter::Found::kNowOnly ? c.now : c.previous) = value / per_report;
  const double var = s.Variance(g);
  if (std::isfinite(var)) c.U = k * std::sqrt(std::max(var, 0.0)) / per_report;
  return c;
}

ComparedParameter OneSide(const Side& s, int i, ComparedParameter::Found found, double k) {
  const auto at = static_cast<std::size_t>(i);
  return OneSide(s.names[at], s.units[at], s, s.values(i), Unit(s, i), s.per_report(i), found, k);
}

std::string Verdict(const CalibrationComparison& cmp) {
  std::vector<const ComparedParameter*> moved;
  int compared = 0;
  std::string alone, without_u;
  for (const ComparedParameter& c : cmp.parameters) {
    if (c.found != ComparedParameter::Found::kBoth) {
      alone += (alone.empty() ? "" : ", ") + c.parameter +
               (c.found == ComparedParameter::Found::kNowOnly ? " (now only)" : " (previous only)");
    } else if (!c.Compared()) {
      without_u += (without_u.empty() ? "" : ", ") + c.parameter;
    } else {
      ++compared;
      if (std::abs(c.En) > 1.0) moved.push_back(&c);
    }
  }
  std::stable_sort(moved.begin(), moved.end(), [](const ComparedParameter* a, const ComparedParameter* b) {
    return std::abs(a->En) > std::abs(b->En);
  });
  std::string v;
  if (compared == 0) {
    v = "nothing compared with an uncertainty";
  } else if (moved.empty()) {
    v = Format("unchanged within uncertainty (%d parameters compared, each |En| <= 1)", compared);
  } else {
    v = "moved:";
    for (std::size_t i = 0; i < moved.size(); ++i) {
      v += (i == 0 ? " " : ", ") + moved[i]->parameter + Format(" by %+.1f U", moved[i]->En);
    }
    v += Format(" (%zu of %d parameters compared have |En| > 1)", moved.size(), compared);
  }
  if (!alone.empty()) {
    v += "; found in one calibration only: " + alone +
         " (the two fits' models differ: the parameters both hold may differ by the change of model, which U does "
         "not include)";
  }
  if (!without_u.empty()) v += "; not compared: " + without_u;
  return v;
}

// Which parameters each calibration holds alone, from the rows of today's own model.
std::string HeldAlone(const CalibrationComparison& own) {
  std::string now_only, previous_only;
  for (const ComparedParameter& c : own.parameters) {
    if (c.found == ComparedParameter::Found::kBoth) continue;
    std::string& list = c.found == ComparedParameter::Found::kNowOnly ? now_only : previous_only;
    list += (list.empty() ? "" : ", ") + c.parameter;
  }
  std::string text;
  if (!now_only.empty()) text += "today's own model holds " + now_only + ", the earlier one does not";
  if (!previous_only.empty()) {
    text += (text.empty() ? "" : "; ") + ("the earlier model holds " + previous_only + ", today's does not");
  }
  return text.empty() ? "the same parameters, fitted beside another drift or form" : text;
}

}  // namespace

CalibrationComparison LikeForLike(CalibrationComparison like, const CalibrationComparison& own) {
  like.model = kPreviousModel;
  for (ComparedParameter& c : like.parameters) c.model = kPreviousModel;
  like.todays_model = own.parameters;
  for (ComparedParameter& c : like.todays_model) c.model = kTodaysModel;
  // What today's own model changes: its value minus the refit's, in units of the refit's U.
  struct Shift {
    const ComparedParameter* like;
    double by, in_u;
  };
  std::vector<Shift> shifts;
  for (const ComparedParameter& l : like.parameters) {
    if (!l.Compared()) continue;
    const auto o = std::find_if(own.parameters.begin(), own.parameters.end(), [&](const ComparedParameter& c) {
      return c.parameter == l.parameter && std::isfinite(c.now);
    });
    if (o != own.parameters.end()) shifts.push_back({&l, o->now - l.now, (o->now - l.now) / l.U});
  }
  std::stable_sort(shifts.begin(), shifts.end(),
                   [](const Shift& a, const Shift& b) { return std::abs(a.in_u) > std::abs(b.in_u); });
  like.models = "the models differ: " + HeldAlone(own) +
                "; compared like with like: today's readings refitted with the earlier calibration's model";
  if (!shifts.empty()) {
    like.models += "; today's own model moves ";
    const std::size_t shown = std::min<std::size_t>(3, shifts.size());
    for (std::size_t i = 0; i < shown; ++i) {
      const Shift& s = shifts[i];
      like.models += (i == 0 ? "" : ", ") + s.like->parameter +
                     Format(" by %+.4g %s (%+.2f U)", s.by, s.like->unit.c_str(), s.in_u);
    }
    like.models += Format(" (the most of the %zu compared; U the like-for-like difference's)", shifts.size());
  }
  return like;
}

CalibrationComparison NotLikeForLike(CalibrationComparison own, const std::string& why) {
  own.models = "the models differ: " + HeldAlone(own) + "; the earlier calibration's model could not be fitted to " +
               "today's readings (" + why + "): compared with today's own model";
  const bool said = std::any_of(own.parameters.begin(), own.parameters.end(), [](const ComparedParameter& c) {
    return c.found != ComparedParameter::Found::kBoth;
  });
  if (!said) {
    own.verdict +=
        "; the two fits' models differ: the parameters both hold may differ by the change of model, which U does "
        "not include";
  }
  return own;
}

bool CalibrationComparison::Unchanged() const {
  const auto compared = [](const ComparedParameter& c) { return c.Compared(); };
  return std::any_of(parameters.begin(), parameters.end(), compared) &&
         std::none_of(parameters.begin(), parameters.end(),
                      [](const ComparedParameter& c) { return c.Compared() && std::abs(c.En) > 1.0; });
}

void CheckComparable(const CalibrationFile& previous, const CalibrationFile& now, const std::string& previous_source) {
  if (!Same(previous.probe_offset_mm, now.probe_offset_mm)) {
    throw Error(previous_source + ": field 'probe_offset_mm' is " + Format("%.9g", previous.probe_offset_mm) +
                " mm, this calibration's nominal d is " + Format("%.9g", now.probe_offset_mm) +
                " mm: the seven errors of another nominal d are not comparable");
  }
}

CalibrationComparison CompareCalibrations(const CalibrationFile& previous, const CalibrationFile& now,
                                          const std::string& previous_source) {
  CheckComparable(previous, now, previous_source);
  CalibrationComparison cmp;
  cmp.previous_source = previous_source;
  const Side prev = SideOf(previous), cur = SideOf(now);
  cmp.correlated_inputs = SharedInputs(prev, cur, cmp.notes);
  const auto n_parameters = [](const Side& s) {
    return static_cast<int>(s.names.size() - s.file->form_terms.size());  // the seven errors and the effects'
  };
  // Today's order (the seven errors, the effects' parameters), then what only the previous holds.
  for (int i = 0; i < n_parameters(cur); ++i) {
    const std::string& name = cur.names[static_cast<std::size_t>(i)];
    const int j = prev.Find(name);
    if (j < 0) {
      cmp.parameters.push_back(OneSide(cur, i, ComparedParameter::Found::kNowOnly, cmp.k));
      continue;
    }
    ComparedParameter c;
    c.parameter = name;
    c.unit = cur.units[static_cast<std::size_t>(i)];
    Difference(c, prev, cur, prev.values(j), Unit(prev, j), cur.values(i), Unit(cur, i), cur.per_report(i),
               cmp.correlated_inputs, cmp.k);
    const std::string why = NotComparable(name, previous, now);
    if (!why.empty()) {
      c.difference = c.U = c.En = kNaN;
      c.note = why;
    }
    cmp.parameters.push_back(c);
  }
  for (int j = 0; j < n_parameters(prev); ++j) {
    if (cur.Find(prev.names[static_cast<std::size_t>(j)]) < 0) {
      cmp.parameters.push_back(OneSide(prev, j, ComparedParameter::Found::kPreviousOnly, cmp.k));
    }
  }
  const auto form_prev = FormRmsOf(prev), form_now = FormRmsOf(cur);
  if (form_prev && form_now) {
    ComparedParameter c;
    c.parameter = "sphere_form.rms";
    c.unit = "um";
    Difference(c, prev, cur, form_prev->first, form_prev->second, form_now->first, form_now->second, kMmPerUm,
               cmp.correlated_inputs, cmp.k);
    cmp.parameters.push_back(c);
  } else if (form_prev || form_now) {
    const auto& [rms, g] = form_now ? *form_now : *form_prev;
    cmp.parameters.push_back(
        OneSide("sphere_form.rms", "um", form_now ? cur : prev, rms, g, kMmPerUm,
                form_now ? ComparedParameter::Found::kNowOnly : ComparedParameter::Found::kPreviousOnly, cmp.k));
  }
  cmp.verdict = Verdict(cmp);
  return cmp;
}

}  // namespace sph
