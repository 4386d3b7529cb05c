// Ambiguities and hold-back in the trace: the candidates the design cannot tell from the effect
// chosen, the measurement that would tell them apart, and, with TraceOptions::hold_confounded,
// both held back.
#include <string_view>

#include "trace_steps.hpp"

namespace sph::internal {

bool Follows(Effect e, std::string_view variable) { return InfoOf(e).variable == variable; }

void NameOnce(std::vector<Ambiguity>* ambiguous, const Ambiguity& a) {
  const auto same = std::find_if(ambiguous->begin(), ambiguous->end(), [&](const Ambiguity& x) {
    return x.form_turns_with_sphere == a.form_turns_with_sphere && x.chosen == a.chosen && x.other == a.other;
  });
  if (same != ambiguous->end()) {
    *same = a;
  } else {
    ambiguous->push_back(a);
  }
}

namespace {

// An effect's class, from the effect catalogue (EffectInfo::variable and quantity): an error of
// the Theta axis, of the Phi axis, of the probe's reading over its range; a translation of the
// Theta spindle (a radial or axial motion, not a rotation).
bool IsThetaMachine(Effect e) { return Follows(e, "theta"); }
bool IsPhiMachine(Effect e) { return Follows(e, "phi"); }
bool IsProbe(Effect e) { return Follows(e, "r"); }
bool IsThetaMotion(Effect e) { return IsThetaMachine(e) && InfoOf(e).quantity == Quantity::kLength; }

bool IsPair(Effect a, Effect b, Effect x, Effect y) { return (a == x && b == y) || (a == y && b == x); }

// The measurement that tells two effects apart, from how each maps onto the readings: by what
// their terms follow (EffectInfo), and for the pairs of one class that only a particular
// measurement separates, by name.
std::string SeparateBy(Effect a, Effect b) {
  if (Follows(a, "t") || Follows(b, "t")) {
    return "repeated reference points: return to one position at the start, middle and end of the run, or measure "
           "the pattern in another order (drift follows time, the other follows the position)";
  }
  if (IsPair(a, b, Effect::kProbeIncidence, Effect::kProbeGain)) {
    return "a second sphere of another radius (sphere_radius_mm@<setup>): at any eccentricity e both leave a term "
           "in sin^2 of the angle on the sphere proportional to e^2, the gain's as 1/R, the incidence's as 1/R^2";
  }
  if (Follows(a, "psi") || Follows(b, "psi")) {
    return "a second sphere position at another eccentricity: the probe's incidence error grows with its square "
           "(sin psi reaches about e / R0), a machine error's signal on the sphere in proportion to it or not at all";
  }
  if ((a == Effect::kThetaTiltMotion && IsThetaMotion(b)) || (b == Effect::kThetaTiltMotion && IsThetaMotion(a))) {
    return "a second sphere position at another height along the Theta axis or another eccentricity: a tilt of the "
           "spindle moves the sphere by its lever (the centre's distance from the pivot), a radial or axial motion by "
           "the same amount wherever the sphere sits";
  }
  if (IsPair(a, b, Effect::kPhiWobble, Effect::kPhiRadialMotion)) {
    return "a larger eccentricity: a tilt of the Phi axis about its pivot at L shifts the probe line by L w along the "
           "beam as a radial motion does, and besides turns it across the surface, which shows only through the "
           "eccentricity (e w against L w)";
  }
  if (IsThetaMachine(a) && IsThetaMachine(b)) {
    return "a second sphere position at another eccentricity or azimuth: an encoder error moves the probed point "
           "along the surface and shows only through the eccentricity, a spindle motion moves the sphere along the "
           "probe line whatever the eccentricity";
  }
  if (IsPhiMachine(a) && IsPhiMachine(b)) {
    return "a second sphere position at another height along the Theta axis, which changes the lever of a Phi axis "
           "tilt but not that of a Phi positioning error";
  }
  if (IsProbe(a) && IsProbe(b)) {
    return "another eccentricity, which changes the range the probe works over";
  }
  return "a second sphere position (another eccentricity or azimuth), which changes how machine errors map onto the "
         "readings";
}

// Whether SeparateBy(a, b) advises another placement of a sphere (all but a drift's advice, which is
// in the time order of the readings).
bool AdvisesPlacement(Effect a, Effect b) { return !Follows(a, "t") && !Follows(b, "t"); }

// What separates them when none of the placements checked does: the advice must not name one.
constexpr const char* kNoPlacementSeparates =
    "no single further placement of the sphere tried tells them apart on this design (checked): several, or one "
    "of the two measured on its own (the probe against a reference, an axis' error against a standard)";

// Whether one more placement would tell apart the candidates last in `a` and `b` (fits of the
// model of `current` with each added), in words; *found: whether one of those tried does.
std::string CheckedSeparation(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                              const EffectFit& a, const EffectFit& b, bool* found) {
  const internal::PairSeparation p = internal::CheckPairSeparation(
      data.points, options, current, a.model.terms.back(), a.values.back(), b.model.terms.back(), b.values.back());
  *found = !p.placement.empty();
  if (!p.placement.empty()) {
    return Format(
        "%s tells them apart (largest variance inflation of their terms fitted together %.3g now, %.3g "
        "with it)",
        p.placement.c_str(), p.vif_now, p.vif_with);
  }
  return Format(
      "none of these tells them apart: %s (largest variance inflation of their terms fitted together %.3g "
      "now, at best %.3g with one of them; at most %.3g would): one of the two measured on its own",
      p.tried.c_str(), p.vif_now, p.vif_with, internal::kSeparatedVif);
}

// Whether the design cannot tell candidate c (fitted in `c_fit`) from the chosen effect (in
// `chosen_fit`), though c scored clearly worse: c explains at least half as much (its delta BIC at
// least half the chosen one's) and, with both beside the current model, a component of the two
// has a variance inflation above internal::kSeparatedVif on the readings as measured. A BIC gap
// between two such terms comes from which components each kept, not from the data telling them
// apart. Where that decides whether anything is added (TraceOptions::hold_confounded), the
// inflation that each term causes the other's components is judged instead (PairInflationNow(),
// above kSeparatedPairInflation):
// a term whose components are poorly determined beside the model anyway must not hold back every
// effect it is compared with.
bool ConfoundedByDesign(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                        const CandidateScore& c, const EffectFit& c_fit, const CandidateScore& chosen,
                        const EffectFit& chosen_fit, const TraceOptions& trace_options) {
  if (!(c.delta_bic <= 0.5 * chosen.delta_bic) || c_fit.model.terms.size() != current.model.terms.size() + 1) {
    return false;
  }
  const EffectTerm& a = chosen_fit.model.terms.back();
  const EffectTerm& b = c_fit.model.terms.back();
  if (!trace_options.hold_confounded) {
    return internal::PairVifNow(data.table, options, current, a, chosen_fit.values.back(), b, c_fit.values.back()) >
           internal::kSeparatedVif;
  }
  return internal::PairInflationNow(data.table, options, current, a, chosen_fit.values.back(), b, c_fit.values.back()) >
         kSeparatedPairInflation;
}
}  // namespace

bool Rival(const Readings& data, const CalibrationOptions& options, const TracedFit& current, const Tried& tried,
           std::size_t i, std::size_t best, const TraceOptions& trace_options, bool* close) {
  const CandidateScore& c = tried[i].first;
  const CandidateScore& chosen = tried[best].first;
  if (i == best || !Admissible(c, current, trace_options)) return false;
  // A candidate held back in an earlier round (TraceOptions::hold_confounded), or any beside a member
  // of a set added together (the round's best single may score far better than the member), may
  // score better than the one chosen now: it is about equal only when the two are within
  // ambiguity_bic either way.
  const double gap = c.delta_bic - chosen.delta_bic;
  const bool either_way = c.held || !chosen.set.empty();
  const bool near = (either_way ? std::abs(gap) : gap) < trace_options.ambiguity_bic;
  if (close != nullptr) *close = near;
  return near ||
         ConfoundedByDesign(data, options, current.fit, c, tried[i].second, chosen, tried[best].second, trace_options);
}

// The ambiguities of the effect chosen in a round: the other admissible candidates that scored
// almost as well or that the design cannot tell from it, and the sphere's form where it explains
// the same change of the residual.
void ChosenAmbiguities(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                       const Tried& tried, std::size_t best, const SpherePattern& sphere, bool form_better,
                       bool form_separable, const TraceOptions& trace_options, CandidateScore& chosen,
                       std::vector<Ambiguity>* ambiguous) {
  for (std::size_t i = 0; i < tried.size(); ++i) {
    const CandidateScore& c = tried[i].first;
    bool close = false;
    if (Rival(data, options, current, tried, i, best, trace_options, &close)) {
      Ambiguity a{InfoOf(chosen.effect).id,           InfoOf(c.effect).id, chosen.delta_bic, c.delta_bic, 0.0,
                  SeparateBy(chosen.effect, c.effect)};
      a.by_design = !close;
      bool found = false;
      a.checked = CheckedSeparation(data, options, current.fit, tried[best].second, tried[i].second, &found);
      if (!found && AdvisesPlacement(chosen.effect, c.effect)) a.separate_by = kNoPlacementSeparates;
      ambiguous->push_back(a);
    }
  }
  // What the effect explains: the change of the residual. When that is mostly a pattern fixed on
  // the sphere, the sphere's own form error explains it as well.
  const EffectFit& with = tried[best].second;
  std::vector<double> signal(data.points.samples.size());
  for (std::size_t i = 0; i < signal.size(); ++i) {
    signal[i] = current.fit.calibration.residuals_mm[i] - with.calibration.residuals_mm[i];
  }
  {
    const internal::StructureJacobian jacobian(data.table, options, current.fit, current.expected_r_mm);
    chosen.sphere_fraction =
        SpherePatternFraction(FactorResidualStructure(ResidualsOfTraced(data, current, jacobian), &signal));
  }
  const double chosen_rms = ExplainedRmsUm(current.fit.calibration.rms_um, with.calibration.rms_um);
  if (form_better) {
    Ambiguity a{InfoOf(chosen.effect).id, "sphere_form",          chosen.delta_bic,
                sphere.delta_bic,         chosen.sphere_fraction, SeparateFromForm(chosen.effect)};
    a.chosen_rms_um = chosen_rms;
    a.other_rms_um = sphere.explained_rms_um;
    ambiguous->push_back(a);
  } else if (!form_separable && chosen.sphere_fraction >= trace_options.max_sphere_fraction) {
    Ambiguity a{InfoOf(chosen.effect).id,
                "sphere_form",
                chosen.delta_bic,
                std::numeric_limits<double>::quiet_NaN(),
                chosen.sphere_fraction,
                "a second setup with the sphere turned on its mount (a form error turns with the sphere, a machine "
                "error stays with the machine), or the sphere's form from its certificate"};
    a.chosen_rms_um = chosen_rms;
    ambiguous->push_back(a);
  }
}

Ambiguity SetAgainstSingle(const Tried& tried, const std::vector<std::size_t>& set, double set_delta_bic,
                           int set_components, std::size_t single, bool set_chosen) {
  const CandidateScore& s = tried[single].first;
  std::vector<std::string> ids;
  std::string joined, separate_by;
  for (const std::size_t m : set) {
    const CandidateScore& c = tried[m].first;
    ids.push_back(c.Id());
    joined += (joined.empty() ? "" : " + ") + c.Id();
    if (m != single) {
      separate_by +=
          (separate_by.empty() ? "" : "; ") + c.Id() + " from " + s.Id() + ": " + SeparateBy(c.effect, s.effect);
    }
  }
  const int single_components = static_cast<int>(s.term.components.size());
  Ambiguity a{set_chosen ? joined : s.Id(),
              set_chosen ? s.Id() : joined,
              set_chosen ? set_delta_bic : s.delta_bic,
              set_chosen ? s.delta_bic : set_delta_bic,
              0.0,
              separate_by};
  (set_chosen ? a.chosen_set : a.other_set) = ids;
  a.chosen_components = set_chosen ? set_components : single_components;
  a.other_components = set_chosen ? single_components : set_components;
  return a;
}

// Whether effect e was held back in this trace (TraceOptions::hold_confounded).
bool IsHeld(const TraceResult& r, Effect e) { return std::find(r.held.begin(), r.held.end(), e) != r.held.end(); }

// With TraceOptions::hold_confounded: whether the candidate `c` just chosen is confounded with
// another library effect (an ambiguity of r.ambiguous from `first_new` on names one). Then neither
// is added: both are held back from later rounds (a third effect chosen later is still judged
// against them, for they are scored every round), the ambiguities say so, and what else was noted
// of the chosen effect (its share that is a pattern on the sphere) is dropped with it.
bool HoldConfounded(std::size_t first_new, CandidateScore& c, TraceResult& r) {
  std::string partners;
  for (auto a = r.ambiguous.begin() + static_cast<std::ptrdiff_t>(first_new); a != r.ambiguous.end(); ++a) {
    Effect e{};
    if (!EffectFromId(a->other, &e)) continue;  // "sphere_form"
    partners += (partners.empty() ? "" : ", ") + a->other +
                (a->by_design ? " (confounded by this design)" : " (about as good a score)");
    a->neither_added = true;
    if (!IsHeld(r, e)) r.held.push_back(e);
  }
  if (partners.empty()) return false;
  r.ambiguous.erase(std::remove_if(r.ambiguous.begin() + static_cast<std::ptrdiff_t>(first_new), r.ambiguous.end(),
                                   [](const Ambiguity& a) { return !a.neither_added; }),
                    r.ambiguous.end());
  r.held.push_back(c.effect);
  c.added = false;
  c.held = true;
  c.sphere_fraction = 0.0;  // of an added effect only
  c.note += std::string(c.note.empty() ? "" : "; ") + "qualifies, but held back: it cannot be told from " + partners +
            ", and neither is added";
  return true;
}
}  // namespace sph::internal
