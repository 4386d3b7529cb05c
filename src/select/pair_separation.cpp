#include "pair_separation.hpp"

#include <algorithm>
#include <cmath>

#include "effect_fit_rows.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::internal {
namespace {

// The variance inflation of each column of the last `n` terms of `fit` on the readings of `table`
// (+inf for a column in the null space).
std::vector<double> LastTermsVifs(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit,
                                  std::size_t n) {
  const NormalInverse inv = NormalInverseAt(table, options, fit);
  const std::size_t n_terms = fit.model.terms.size();
  const int first = fit.TermOffset(n_terms - n);
  const int last = fit.TermOffset(n_terms - 1) + fit.model.terms.back().size();
  std::vector<double> out;
  for (int j = first; j < last; ++j) {
    const auto col = static_cast<Eigen::Index>(j);
    const double vif = inv.in_null[static_cast<std::size_t>(j)]
                           ? std::numeric_limits<double>::infinity()
                           : inv.inverse(col, col) / (inv.scale(col) * inv.scale(col));
    out.push_back(std::isnan(vif) ? std::numeric_limits<double>::infinity() : vif);
  }
  return out;
}

// The largest variance inflation of the columns of the last two terms of `fit` on the readings of
// `table`.
double PairVif(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit) {
  const std::vector<double> vifs = LastTermsVifs(table, options, fit, 2);
  return vifs.empty() ? 0.0 : *std::max_element(vifs.begin(), vifs.end());
}

// `points` with the rows of its first setup read once more at placement `p` (setup ids from one
// above the highest, one per orientation), at the fitted geometry of `fit`, and `options` with the
// radius of its sphere; false when a ray misses. The setups' ids are appended to `setups`.
bool WithPlacement(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                   const Placement& p, PointsData* out, CalibrationOptions* out_options, std::vector<int>* setups) {
  *out = points;
  *out_options = options;
  const std::vector<int>& ids = fit.calibration.setup_ids;
  const double radius_mm = p.other_radius_mm > 0.0 ? p.other_radius_mm : options.sphere_radius_mm;
  const std::size_t n_setups = std::max<std::size_t>(1, p.rotations_deg.size());
  for (std::size_t k = 0; k < n_setups; ++k) {
    const int setup = ids.back() + 1 + static_cast<int>(k);
    setups->push_back(setup);
    if (p.other_radius_mm > 0.0) {
      out->header.sphere_radii_mm[setup] = radius_mm;
      out_options->sphere_radii_mm[setup] = radius_mm;
    }
    if (k < p.rotations_deg.size()) out->header.mount_rotations[setup] = MountRotation{p.rotations_deg[k]};
    for (const Sample& s : points.samples) {
      if (s.setup != ids.front()) continue;
      // A perfect sphere reads alike in any orientation; the rotation turns only its form's terms.
      const std::optional<double> r = ProbeReading(fit.calibration.geometry, s.theta_rad(), s.phi_rad(),
                                                   options.probe_offset_mm, p.center_mm, radius_mm);
      if (!r) return false;
      Sample again = s;
      again.r_mm = *r;
      again.setup = setup;
      out->samples.push_back(again);
    }
  }
  out->has_setup = true;
  return true;
}

}  // namespace

std::vector<Placement> PlacementsToTry(const Eigen::Vector3d& c0, double sphere_radius_mm, bool with_form) {
  const double e = std::hypot(c0.x(), c0.y());
  std::vector<Placement> out;
  const auto add = [&out](const Eigen::Vector3d& center_mm, std::string words) {
    Placement& p = out.emplace_back();
    p.center_mm = center_mm;
    p.words = std::move(words);
    return &p;
  };
  if (e >= 0.5) {
    add(Eigen::Vector3d(0.5 * c0.x(), 0.5 * c0.y(), c0.z()),
        Format("a second placement at half the eccentricity (%.3g mm)", 0.5 * e));
    add(Eigen::Vector3d(3.0 * c0.x(), 3.0 * c0.y(), c0.z()),
        Format("a second placement at three times the eccentricity (%.3g mm)", 3.0 * e));
  } else {
    add(Eigen::Vector3d(2.0, 0.0, c0.z()), "a second placement at 2 mm eccentricity");
  }
  add(Eigen::Vector3d(-c0.y(), c0.x(), c0.z()),
      "a second placement at the same eccentricity, 90 deg further round the Theta axis");
  for (const double fraction : {0.25, 0.75}) {  // of the sphere's radius
    const double up_mm = fraction * sphere_radius_mm;
    add(c0 + Eigen::Vector3d(0.0, 0.0, up_mm), Format("a second placement %.3g mm higher along the Theta axis", up_mm));
  }
  const double half_mm = 0.5 * sphere_radius_mm;
  Placement* other =
      add(c0, with_form ? Format("a second sphere, of radius %.3g mm, in the same place, measured in two "
                                 "orientations 90 deg apart about y (sphere_radius_mm@<setup>, "
                                 "mount_rotation_deg@<setup>)",
                                 half_mm)
                        : Format("a second sphere, of radius %.3g mm, in the same place "
                                 "(sphere_radius_mm@<setup>)",
                                 half_mm));
  other->other_radius_mm = half_mm;
  if (with_form) other->rotations_deg = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 90.0, 0.0)};
  return out;
}

namespace {

// `current` with the terms a and b added last, at their values.
EffectFit WithPair(const EffectFit& current, const EffectTerm& a, const std::vector<double>& a_values,
                   const EffectTerm& b, const std::vector<double>& b_values) {
  EffectFit both = current;
  both.model.terms.push_back(a);
  both.model.terms.push_back(b);
  both.values.push_back(a_values);
  both.values.push_back(b_values);
  both.n_params += a.size() + b.size();
  return both;
}

}  // namespace

double PairInflationNow(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& current,
                        const EffectTerm& a, const std::vector<double>& a_values, const EffectTerm& b,
                        const std::vector<double>& b_values) {
  const std::vector<double> both = LastTermsVifs(table, options, WithPair(current, a, a_values, b, b_values), 2);
  std::vector<double> alone;
  for (const auto& [term, values] : {std::pair{&a, &a_values}, std::pair{&b, &b_values}}) {
    EffectFit one = current;
    one.model.terms.push_back(*term);
    one.values.push_back(*values);
    one.n_params += term->size();
    const std::vector<double> v = LastTermsVifs(table, options, one, 1);
    alone.insert(alone.end(), v.begin(), v.end());
  }
  double factor = 1.0;
  for (std::size_t k = 0; k < both.size() && k < alone.size(); ++k) {
    // A column already undetermined alone says nothing of the pair.
    if (std::isfinite(alone[k])) factor = std::max(factor, both[k] / alone[k]);
  }
  return factor;
}

double PairVifNow(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& current,
                  const EffectTerm& a, const std::vector<double>& a_values, const EffectTerm& b,
                  const std::vector<double>& b_values) {
  return PairVif(table, options, WithPair(current, a, a_values, b, b_values));
}

PairSeparation CheckPairSeparation(const PointsData& points, const CalibrationOptions& options,
                                   const EffectFit& current, const EffectTerm& a, const std::vector<double>& a_values,
                                   const EffectTerm& b, const std::vector<double>& b_values) {
  const EffectFit both = WithPair(current, a, a_values, b, b_values);
  PairSeparation out;
  out.vif_now = PairVif(ReadingTable(points), options, both);
  const Eigen::Vector3d& c0 = current.calibration.centers_mm.front();
  for (const Placement& p : PlacementsToTry(c0, options.sphere_radius_mm, !current.model.form.Empty())) {
    out.tried += (out.tried.empty() ? "" : "; ") + p.words;
    PointsData more;
    CalibrationOptions more_options;
    std::vector<int> setups;
    if (!WithPlacement(points, options, current, p, &more, &more_options, &setups)) continue;
    EffectFit with = both;
    for (const int setup : setups) {
      with.calibration.setup_ids.push_back(setup);
      with.calibration.centers_mm.push_back(p.center_mm);
      with.n_params += 3;
    }
    if (!with.model.form.Empty()) {  // another sphere has a form of its own: a group of its own
      with.model.form = FormModelOf(more, with.model.form.terms);
      const auto n_groups = static_cast<std::size_t>(with.model.form.NumGroups());
      with.n_params += static_cast<int>((n_groups - with.form_values.size()) * with.model.form.terms.size());
      with.form_values.resize(n_groups, std::vector<double>(with.model.form.terms.size(), 0.0));
    }
    const double vif = PairVif(ReadingTable(more), more_options, with);
    if (vif < out.vif_with) {
      out.vif_with = vif;
      if (vif <= kSeparatedVif) out.placement = p.words;
    }
  }
  return out;
}

}  // namespace sph::internal
