// The rounds of the trace: each forward round's choice among the scored candidates (admissible,
// beside the form, against the sphere's own pattern), the components of earlier terms chosen
// again, and the backward removal of the effects the final model no longer needs.
#include <optional>

#include "trace_steps.hpp"

namespace sph::internal {
namespace {

// Whether `c`, with two or more setups, predicts the setups left out clearly worse than the model
// without it (CandidateScore::loso_t): what a form or another function of the sphere's direction
// fitted as a machine error does (it turns with the sphere, a machine error does not).
bool Untransferred(const CandidateScore& c, const TraceOptions& trace_options) {
  return c.loso_t > trace_options.min_t;
}
}  // namespace

// Whether a candidate may be added to `current`: a term with something to fit, every parameter
// determined, a BIC lower by trace_options.min_delta_bic, a lower cross-validated RMS, and, with two or
// more setups, not Untransferred().
bool Admissible(const CandidateScore& c, const TracedFit& current, const TraceOptions& trace_options) {
  return !c.term.components.empty() && c.determined && c.delta_bic <= -trace_options.min_delta_bic &&
         c.cv_rms_um < current.cv_rms_um && !Untransferred(c, trace_options);
}

namespace {

// The admissible candidate of `tried` with the lowest delta BIC among those `also` accepts; -1:
// none.
template <typename Also>
int BestAdmissible(const Tried& tried, const TracedFit& current, const TraceOptions& trace_options, Also also) {
  int best = -1;
  for (std::size_t i = 0; i < tried.size(); ++i) {
    const CandidateScore& c = tried[i].first;
    if (Admissible(c, current, trace_options) && !c.held && also(c) &&
        (best < 0 || c.delta_bic < tried[static_cast<std::size_t>(best)].first.delta_bic)) {
      best = static_cast<int>(i);
    }
  }
  return best;
}

// The competitor no effect of the library is: a pattern fixed on the sphere (its form error, or an
// effect outside the library), the spherical harmonics that the BIC keeps, scored as if added to
// the current fit (its note is written once the round is decided: SphereCompetitorNote()).
CandidateScore SphereCompetitor(const SpherePattern& sphere, const TracedFit& current, int round) {
  CandidateScore form;
  form.sphere_form = true;
  form.round = round;
  form.delta_bic = sphere.delta_bic;
  const double rms_um = current.fit.calibration.rms_um;
  form.rms_um = std::sqrt(std::max(0.0, rms_um * rms_um - sphere.explained_rms_um * sphere.explained_rms_um));
  form.cv_rms_um = std::numeric_limits<double>::quiet_NaN();
  return form;
}

std::string SphereCompetitorNote(const SpherePattern& sphere, bool form_better, bool form_wins) {
  std::string functions;
  for (const std::string& f : sphere.functions) functions += (functions.empty() ? "" : " ") + f;
  return "a pattern fixed on the sphere, spherical harmonics of the direction from the centre, linearised: " +
         (functions.empty() ? std::string("none lowers the BIC")
                            : functions + (form_wins     ? "; explains the residual as well as any effect of the "
                                                           "library or better, so none is added"
                                           : form_better ? "; explains as much as the best effect or more, which "
                                                           "its own variable shows, so both are reported"
                                                         : "; less than the best effect"));
}

// Why candidate c was not added, appended to its note. `best`: the candidate added, if any.
void NoteWhyNotAdded(CandidateScore& c, bool admissible, bool form_wins, const CandidateScore* best,
                     const TracedFit& current, const TraceOptions& trace_options) {
  if (c.added) return;
  std::string why;
  if (admissible && form_wins) {
    why = "qualifies, but a pattern fixed on the sphere explains as much or more";
  } else if (admissible && best != nullptr && best->delta_bic <= c.delta_bic) {
    why = "qualifies; " + best->Id() + Format(" scored better (delta BIC %.1f)", best->delta_bic);
  } else if (admissible && best != nullptr) {
    // A better score, but not eligible: a pattern fixed on the sphere explains about as much, and
    // its own variable does not show it beyond that pattern, as it does the one added.
    why = Format(
              "qualifies with a better score than %s (delta BIC %.1f against %.1f), but a pattern fixed on the "
              "sphere explains about as much and its own variable does not show it beyond that pattern; ",
              best->Id().c_str(), c.delta_bic, best->delta_bic) +
          best->Id() + "'s does";
  } else if (!c.term.components.empty() && c.determined) {
    if (c.delta_bic > -trace_options.min_delta_bic) {
      why = "too small a gain (delta BIC above -" + Format("%g", trace_options.min_delta_bic) + ")";
    } else if (!(c.cv_rms_um < current.cv_rms_um)) {
      why = "no lower cross-validated RMS";
    } else {
      why = Format(
          "does not transfer between setups: each predicted from the others %.4f um rms with it, %.4f um "
          "without (paired t %.1f)",
          c.loso_rms_um, current.loso_rms_um, c.loso_t);
    }
  }
  if (!why.empty()) c.note += std::string(c.note.empty() ? "" : "; ") + why;
}

// The measurement that separates a probe effect from a form that turns with the sphere.
constexpr const char* kSeparateFromTurningForm =
    "orientations of the sphere on its mount that point the eccentricity elsewhere on its body, or a second "
    "eccentricity (sph_montecarlo --plan-orientations proposes orientations)";

// With a design that separates the form: the best admissible candidate of `tried` that still
// qualifies beside the form of the highest degree searched (ShownBeyondForm()), or -1. Those that
// qualify only without it get a note, go into *not_beyond_form and are reported in r.ambiguous as
// two explanations with that form, once per candidate (a later round's sizes replace an earlier's).
int BestBesideForm(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   const TraceOptions& trace_options, Tried& tried, TraceResult& r, std::set<Effect>* not_beyond_form) {
  const EffectFit full = FullForm(data, options, current, r.form);
  std::map<Effect, double> beyond;  // the candidates tried: their extended BIC beside that form
  const int best = BestAdmissible(tried, current, trace_options, [&](const CandidateScore& c) {
    return ShownBeyondForm(data, options, c, full, trace_options, &beyond[c.effect]);
  });
  const double cur_rms = current.fit.calibration.rms_um, full_rms = full.calibration.rms_um;
  for (auto& [c, fit] : tried) {
    const auto b = beyond.find(c.effect);
    if (b == beyond.end() || b->second <= -trace_options.min_delta_bic) continue;
    not_beyond_form->insert(c.effect);
    c.note +=
        std::string(c.note.empty() ? "" : "; ") +
        (std::isnan(b->second)
             ? Format("qualifies, but is not separable from the sphere's form of degrees 2..%d", r.form.degree_limit)
             : Format("qualifies, but not beside the sphere's form of degrees 2..%d (delta BIC %.1f there)",
                      r.form.degree_limit, b->second));
    Ambiguity a{"sphere_form", c.Id(), std::numeric_limits<double>::quiet_NaN(),
                c.delta_bic,   0.0,    kSeparateFromTurningForm};
    a.chosen_rms_um = ExplainedRmsUm(cur_rms, full_rms);
    a.other_rms_um = ExplainedRmsUm(cur_rms, c.rms_um);
    a.form_turns_with_sphere = true;
    NameOnce(&r.ambiguous, a);
  }
  return best;
}

// Whether two terms have the same components (in any order).
bool SameComponents(const EffectTerm& a, const EffectTerm& b) {
  const auto key = [](const EffectTerm& t) {
    std::vector<std::tuple<int, int, bool>> k;
    for (const EffectComponent& c : t.components) k.emplace_back(c.order, c.axis, c.sine);
    std::sort(k.begin(), k.end());
    return k;
  };
  return a.effect == b.effect && key(a) == key(b);
}

// The components of the effects already in the model chosen again beside the one just added (the
// last term). A term's components were chosen when it joined the model, against the residual of
// that model: a large effect not yet fitted can hide a component of it (a probe gain of 10 um hides
// the linear part of a drift fitted before it, and a Theta encoder's c1 then takes the drift's
// place). Each earlier term is fitted again from all of its components, beside every other term,
// with FitCandidate()'s rule, and taken when the extended BIC falls.
void RefreshComponents(const Readings& data, const CalibrationOptions& options, const TraceOptions& trace_options,
                       TracedFit& current) {
  const std::vector<Effect> stated = StatedEffects(options);  // their components as stated
  for (std::size_t t = 0; t + 1 < current.fit.model.terms.size(); ++t) {
    const EffectTerm& term = current.fit.model.terms[t];
    if (std::find(stated.begin(), stated.end(), term.effect) != stated.end()) continue;
    const EffectTerm full = DefaultTerm(term.effect, trace_options.harmonics, trace_options.drift_order);
    if (SameComponents(term, full)) continue;
    EffectModel model = current.fit.model;
    model.terms.erase(model.terms.begin() + static_cast<std::ptrdiff_t>(t));
    EffectFitStart start = EffectFitStart::From(current.fit);
    start.values.erase(start.values.begin() + static_cast<std::ptrdiff_t>(t));
    const EffectFit without = internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
    if (!without.calibration.converged) continue;
    std::string note;
    EffectFit again = FitCandidate(data, options, without, full, trace_options, &note);
    if (again.model.terms.size() != current.fit.model.terms.size() || !again.calibration.converged) continue;
    const EffectTerm& chosen = again.model.terms.back();
    if (SameComponents(chosen, term)) continue;
    const double change =
        again.Bic() + SearchPenalty(chosen, trace_options) - current.fit.Bic() - SearchPenalty(term, trace_options);
    if (!(change < 0.0)) continue;
    // The term moves to the end of the model; the one just added stays last.
    EffectFit reordered = std::move(again);
    std::rotate(reordered.model.terms.end() - 2, reordered.model.terms.end() - 1, reordered.model.terms.end());
    std::rotate(reordered.values.end() - 2, reordered.values.end() - 1, reordered.values.end());
    reordered = internal::FitEffectsRows(data.points, data.table, nullptr, options, reordered.model,
                                         EffectFitStart::From(reordered));
    current = Analysed(std::move(reordered), data, options, trace_options);
    --t;  // the term now at index t is the next one to look at
  }
}

// The eligible candidates of a round: admissible, not held back, not explained as well by the form
// (`not_beyond_form`), and, when a pattern on the sphere explains about as much as the best, shown
// beyond it by their own variable: those a round may add, alone or in a set.
std::vector<std::size_t> Eligible(const Tried& tried, const TracedFit& current, bool form_better,
                                  const std::set<Effect>& not_beyond_form, const TraceOptions& trace_options) {
  const bool one_placement = OnePlacement(current.fit);
  std::vector<std::size_t> eligible;
  for (std::size_t i = 0; i < tried.size(); ++i) {
    const CandidateScore& c = tried[i].first;
    if (Admissible(c, current, trace_options) && !c.held && not_beyond_form.count(c.effect) == 0 &&
        (!form_better || ShownBeyondSphere(c, current.factor, one_placement, trace_options))) {
      eligible.push_back(i);
    }
  }
  return eligible;
}

// The set BestCombination() chose, added: each member's note names the others, the set's score and
// the round's best single effect it was chosen over; each member's ambiguities with the candidates
// outside the set are named as a single's are (ChosenAmbiguities()); the other candidates' notes
// say why they were not added.
void AddSet(const Readings& data, const CalibrationOptions& options, const TraceOptions& trace_options, ChosenSet set,
            std::size_t best, const SpherePattern& sphere, bool form_better, const std::set<Effect>& not_beyond_form,
            Tried& tried, TracedFit& current, TraceResult& r) {
  std::vector<std::string> ids;
  for (const std::size_t i : set.members) ids.push_back(tried[i].first.Id());
  std::string all;
  for (const std::string& id : ids) all += (all.empty() ? "" : " + ") + id;
  const CandidateScore single = tried[best].first;
  for (const std::size_t i : set.members) {
    CandidateScore& c = tried[i].first;
    std::string others;
    for (const std::string& id : ids) {
      if (id != c.Id()) others += (others.empty() ? "" : ", ") + id;
    }
    c.added = true;
    c.set = ids;
    c.set_delta_bic = set.delta_bic;
    c.set_over = single.Id();
    c.set_over_delta_bic = single.delta_bic;
    c.note += std::string(c.note.empty() ? "" : "; ") + "added together with " + others +
              Format(": delta BIC of the set %.1f (charged for the search among sets), against %s alone %.1f",
                     set.delta_bic, single.Id().c_str(), single.delta_bic);
    r.added.push_back(c.effect);
  }
  for (const std::size_t i : set.members) {
    std::vector<Ambiguity> found;
    ChosenAmbiguities(data, options, current, tried, i, sphere, form_better, r.form.separable, trace_options,
                      tried[i].first, &found);
    for (const Ambiguity& a : found) {
      if (std::find(ids.begin(), ids.end(), a.other) == ids.end()) r.ambiguous.push_back(a);
    }
  }
  for (auto& [c, fit] : tried) {
    if (c.added) continue;
    if (c.held) {
      c.note += std::string(c.note.empty() ? "" : "; ") + "held back: confounded with another effect, neither added";
    } else if (not_beyond_form.count(c.effect) == 0) {
      if (Admissible(c, current, trace_options)) {
        c.note += std::string(c.note.empty() ? "" : "; ") +
                  (set.delta_bic <= c.delta_bic
                       ? Format("qualifies; the set %s scored better (delta BIC %.1f)", all.c_str(), set.delta_bic)
                       : Format("qualifies; the set %s was chosen (delta BIC %.1f, charged for the search among "
                                "sets, against this one's %.1f)",
                                all.c_str(), set.delta_bic, c.delta_bic));
      } else {
        NoteWhyNotAdded(c, false, false, nullptr, current, trace_options);
      }
    }
  }
  for (auto& [c, fit] : tried) r.candidates.push_back(c);
  current = Analysed(std::move(set.fit), data, options, trace_options);
  RefreshComponents(data, options, trace_options, current);
}
}  // namespace

// One forward round: every effect of `pool` not yet in the model scored against `current`; the
// best admissible one is added, or a set of up to `max_set` that explains the residual better
// (BestCombination()) (true), or none is and the search ends (false). The round's scores and
// ambiguities go into `r`.
bool ForwardRound(const Readings& data, const CalibrationOptions& options, const std::vector<Effect>& pool, int round,
                  int max_set, const TraceOptions& trace_options, TracedFit& current, TraceResult& r) {
  std::vector<Effect> todo;
  for (Effect e : pool) {
    if (current.fit.model.Find(e) < 0) todo.push_back(e);
  }
  Tried tried = ScoreCandidates(data, options, current, todo, round, trace_options);
  for (auto& [c, fit] : tried) c.held = IsHeld(r, c.effect);
  // Admissible, but a form explains them as well: a pattern on each setup's sphere here, a form of
  // a higher degree beside the form fitted below (BestBesideForm()).
  std::set<Effect> not_beyond_form;
  NotBeyondEachSetupsPattern(data, options, current, trace_options, tried, r, &not_beyond_form);
  const auto any = [&](const CandidateScore& c) { return not_beyond_form.count(c.effect) == 0; };
  int best = BestAdmissible(tried, current, trace_options, any);
  // With a design that separates the form, it is in the model and no competitor. When the
  // competitor explains the residual better than the best effect, or about as well, no effect is
  // added.
  const SpherePattern sphere = r.form.separable ? SpherePattern{} : CompetingSpherePattern(data, options, current);
  CandidateScore form = SphereCompetitor(sphere, current, round);
  // Within ambiguity_bic of the best effect the pattern counts as better: two explanations about
  // equal, and a machine effect is the claim that must be shown.
  const bool form_better = PatternAboutAsGood(
      sphere,
      best < 0 ? std::numeric_limits<double>::infinity() : tried[static_cast<std::size_t>(best)].first.delta_bic,
      trace_options);
  // A pattern on the sphere never blocks an effect that its own variable shows: the best such
  // candidate is added, and both explanations are reported.
  if (form_better && best >= 0) {
    const bool one_placement = OnePlacement(current.fit);
    best = BestAdmissible(tried, current, trace_options, [&](const CandidateScore& c) {
      return any(c) && ShownBeyondSphere(c, current.factor, one_placement, trace_options);
    });
  }
  const bool form_wins = form_better && best < 0;
  form.note = SphereCompetitorNote(sphere, form_better, form_wins);
  if (r.form.separable && best >= 0 && r.form.degree_limit > r.form.degree_max) {
    best = BestBesideForm(data, options, current, trace_options, tried, r, &not_beyond_form);
  }
  std::optional<Ambiguity> set_about_equal;  // a set about as good as the single, not chosen
  if (best >= 0 && !form_wins && max_set > 1) {
    ChosenSet set = BestCombination(data, options, current, tried, static_cast<std::size_t>(best),
                                    Eligible(tried, current, form_better, not_beyond_form, trace_options), r.form,
                                    sphere, max_set, trace_options);
    if (!set.members.empty()) {
      // Chosen over a single about as good for its fewer components: both explanations are named.
      if (set.delta_bic > tried[static_cast<std::size_t>(best)].first.delta_bic - trace_options.ambiguity_bic) {
        r.ambiguous.push_back(
            SetAgainstSingle(tried, set.members, set.delta_bic, set.components, static_cast<std::size_t>(best), true));
      }
      AddSet(data, options, trace_options, std::move(set), static_cast<std::size_t>(best), sphere, form_better,
             not_beyond_form, tried, current, r);
      if (!r.form.separable) r.candidates.push_back(form);
      return true;
    }
    if (!set.about_equal.empty()) {
      set_about_equal = SetAgainstSingle(tried, set.about_equal, set.about_equal_delta_bic, set.about_equal_components,
                                         static_cast<std::size_t>(best), false);
    }
  }
  const CandidateScore* chosen = nullptr;
  bool hold = false;  // the chosen one cannot be told from another effect, and neither is added
  if (best < 0 || form_wins) {
    // An effect of the time or the probe reading that its variable shows, but no more than a form
    // would, and the best effect of the machine: both explanations, neither added.
    const int best_machine = form_wins ? BestAdmissible(tried, current, trace_options,
                                                        [](const CandidateScore& c) { return IsAxisError(c.effect); })
                                       : -1;
    for (std::size_t i = 0; i < tried.size(); ++i) {
      const CandidateScore& c = tried[i].first;
      const bool shown = ShownByItsVariable(c.effect, current.structure, trace_options);
      if (!form_wins || !Admissible(c, current, trace_options) || !(shown || static_cast<int>(i) == best_machine) ||
          not_beyond_form.count(c.effect) != 0)
        continue;
      Ambiguity a{"sphere_form", c.Id(), sphere.delta_bic, c.delta_bic, 0.0, SeparateFromForm(c.effect)};
      a.chosen_rms_um = sphere.explained_rms_um;
      a.other_rms_um = ExplainedRmsUm(current.fit.calibration.rms_um, c.rms_um);
      r.ambiguous.push_back(a);
    }
  } else {
    CandidateScore& c = tried[static_cast<std::size_t>(best)].first;
    c.added = true;
    const std::size_t first_new = r.ambiguous.size();
    ChosenAmbiguities(data, options, current, tried, static_cast<std::size_t>(best), sphere, form_better,
                      r.form.separable, trace_options, c, &r.ambiguous);
    chosen = &c;
    if (trace_options.hold_confounded) hold = HoldConfounded(first_new, c, r);
    if (set_about_equal && !hold) r.ambiguous.push_back(*set_about_equal);
    if (hold) {
      for (auto& [other, fit] : tried) other.held = IsHeld(r, other.effect);  // its partners too
      if (form_better) form.note += "; the effect it was compared with is held back";
    }
  }
  for (auto& [c, fit] : tried) {
    if (not_beyond_form.count(c.effect) == 0 && !c.held) {
      NoteWhyNotAdded(c, Admissible(c, current, trace_options), form_wins, chosen, current, trace_options);
    } else if (c.held && !(hold && &c == chosen)) {
      c.note += std::string(c.note.empty() ? "" : "; ") + "held back: confounded with another effect, neither added";
    }
    r.candidates.push_back(c);
  }
  if (!r.form.separable) r.candidates.push_back(form);
  if (hold) return true;  // the next round chooses among the others, still judged against those held
  if (chosen == nullptr) return false;
  r.added.push_back(chosen->effect);
  current = Analysed(std::move(tried[static_cast<std::size_t>(best)].second), data, options, trace_options);
  RefreshComponents(data, options, trace_options, current);
  return true;
}

// Backward: an effect that the final model no longer needs (the BIC without it is less than
// min_delta_bic higher) is removed, the least needed first, and the rest refitted.
void RemoveUnneeded(const Readings& data, const CalibrationOptions& options, const TraceOptions& trace_options,
                    TracedFit& current, TraceResult& r) {
  while (!current.fit.model.terms.empty()) {
    int weakest = -1;
    double least = std::numeric_limits<double>::infinity();
    EffectFit without_weakest;
    for (std::size_t t = 0; t < current.fit.model.terms.size(); ++t) {
      if (std::find(r.stated.begin(), r.stated.end(), current.fit.model.terms[t].effect) != r.stated.end()) continue;
      EffectModel model = current.fit.model;
      model.terms.erase(model.terms.begin() + static_cast<std::ptrdiff_t>(t));
      EffectFitStart start = EffectFitStart::From(current.fit);
      start.values.erase(start.values.begin() + static_cast<std::ptrdiff_t>(t));
      EffectFit w = internal::FitEffectsRows(data.points, data.table, nullptr, options, model, start);
      const double cost = w.Bic() - current.fit.Bic() - SearchPenalty(current.fit.model.terms[t], trace_options);
      if (w.calibration.converged && cost < least) {
        least = cost;
        weakest = static_cast<int>(t);
        without_weakest = std::move(w);
      }
    }
    if (weakest < 0 || least >= trace_options.min_delta_bic) break;
    const Effect e = current.fit.model.terms[static_cast<std::size_t>(weakest)].effect;
    r.removed.emplace_back(e, least);
    r.added.erase(std::find(r.added.begin(), r.added.end(), e));
    current = Analysed(std::move(without_weakest), data, options, trace_options);
  }
}
}  // namespace sph::internal
