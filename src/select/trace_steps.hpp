// Private to the selection: the steps of TraceResidual() and FitFixedEffects() (trace.cpp), a
// file each: the candidates (trace_candidates.cpp), sets of them (trace_combinations.cpp), the
// sphere's form (trace_form.cpp), the transfer test (trace_transfer.cpp), ambiguities and hold-back
// (trace_hold_back.cpp), the rounds (trace_rounds.cpp); the reports are trace_report.cpp.
#ifndef SPH_SRC_SELECT_TRACE_STEPS_HPP_
#define SPH_SRC_SELECT_TRACE_STEPS_HPP_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <Eigen/QR>

#include "effect_fit_rows.hpp"
#include "fit_problem.hpp"
#include "pair_separation.hpp"
#include "sph/core/error.hpp"
#include "sph/stats/gum.hpp"
#include "sph/io/setup_checks.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/parallel.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"
#include "sph/select/form_report.hpp"
#include "sph/select/identifiability.hpp"
#include "sph/select/trace.hpp"
#include "structure_jacobian.hpp"

namespace sph::internal {

// The readings a trace fits and their table, built once for every candidate, fold and refit.
struct Readings {
  PointsData points;
  internal::ReadingTable table;
  explicit Readings(PointsData p) : points(std::move(p)), table(points) {}
};

// The fewest samples that a fit of the cross-validation fits (CrossValidated(): each fold holds
// every `folds`-th sample of each setup, the first fold the most), and the most a fold leaves out.
struct FoldSizes {
  std::size_t fewest_fitted = 0, most_left_out = 0;
};

// The candidates of one round, each added to the current fit and scored.
using Tried = std::vector<std::pair<CandidateScore, EffectFit>>;

// The extended BIC's charge for the components `term` keeps of those its effect's default term
// searched (FitCandidate() keeps only the separable and significant ones).
double SearchPenalty(const EffectTerm& term, const TraceOptions& trace_options);

// The fold sizes of a cross-validation of `points` in `folds` folds.
FoldSizes FoldSizesOf(const PointsData& points, int folds);

// Throws sph::Error, in the terms of the file, when the cross-validation of a model of n_params
// parameters (`what` they are) cannot fit them: a fit needs more samples than parameters. The
// seven-error calibration alone needs more than base_params.
void CheckFoldsCanFit(const PointsData& points, int folds, int n_params, const std::string& what, int base_params);

// What the residual analyses need of a traced fit.
FitResiduals ResidualsOfTraced(const Readings& data, const TracedFit& t, const JacobianBlocks& jacobian);

// `fit` with its expected readings, directions and residual's factor (TracedFit::factor) only:
// what the checks against a pattern on the sphere need, without the cross-validation.
TracedFit Factored(EffectFit fit, const Readings& data, const CalibrationOptions& options);

// `fit` with what the trace judges it by: its residual's structure, its cross-validated RMS and its
// prediction of each setup from the others.
TracedFit Analysed(EffectFit fit, const Readings& data, const CalibrationOptions& options,
                   const TraceOptions& trace_options);

// The model of `current` with `term` added, fitted; components that the data cannot separate or
// do not show are left out (Eliminate(): after each fit, all that the rule drops at it, then
// refitted). The last term of the returned fit is the candidate (absent when nothing of it is left).
EffectFit FitCandidate(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                       EffectTerm term, const TraceOptions& trace_options, std::string* note);

// Whether the design separates the sphere's form from the machine (the sphere measured in at least
// two known orientations), and the highest degree the pattern resolves: a degree-L harmonic has L
// cycles around the sphere, so it needs more than 2L points on each ring and more than L rings.
FormSelection FormDesign(const PointsData& points, const TraceOptions& trace_options);

// Which form terms of degrees 2..degree_limit the design cannot tell from the seven errors, the
// centres and the candidates of `pool` (linearised at `base`), in words. They stay in the search
// (the form is fitted before any effect, so no machine term they are confounded with is in the
// model with them); the report says that their split with the machine is not known.
void ConfoundedFormTerms(const Readings& data, const CalibrationOptions& options, const EffectFit& base,
                         const std::vector<Effect>& pool, const TraceOptions& trace_options, FormSelection* sel);

// The fit of `current`'s model with the sphere's form of degrees 2..L, for the L that minimises
// the extended BIC (BIC + 2 ln N, N the degrees searched), or the model without a form when no L
// lowers it by min_delta_bic. sel->delta_ebic gets each degree's score.
EffectFit SelectFormDegree(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                           const TraceOptions& trace_options, FormSelection* sel);

// Whether effect e is a function of `variable` (EffectInfo::variable: "theta", "phi", "r", "t",
// "psi"): the time for a drift, the probe reading for the probe's polynomial terms.
bool Follows(Effect e, std::string_view variable);

// What a change of the model explains of the residual, as an RMS [um]: sqrt(before^2 - after^2)
// of the RMS of two nested fits, the larger model's after.
inline double ExplainedRmsUm(double rms_before_um, double rms_after_um) {
  return std::sqrt(std::max(0.0, rms_before_um * rms_before_um - rms_after_um * rms_after_um));
}

// Adds `a` to *ambiguous, or replaces the one that names the same two explanations (a later
// round's sizes replace an earlier round's): each pair is reported once.
void NameOnce(std::vector<Ambiguity>* ambiguous, const Ambiguity& a);

// Whether the sphere sat in one place for every setup (their centres within 10 um): the probe
// reading is then, like the time of a single pass, a function of the direction on the sphere, and
// a smooth one (to first order e . n, e the eccentricity).
bool OnePlacement(const EffectFit& fit);

// Whether the candidate follows a variable that a pattern fixed on the sphere is not (the time for
// probe_drift, the probe reading for the probe terms) and the residual shows its functions of that
// variable beyond any form of degree 2..5: the linearised BIC of J, every such harmonic and the
// term's powers against J and the harmonics alone falls by at least min_delta_bic. Never for a
// probe term with the sphere in one placement: a power of the reading is then a form of low degree
// (u^k of degree about k), and what it shows beyond degrees 2..5 is a higher degree of the form
// (the sphere's own, of degree 6 and more) that the reading's small higher terms happen to follow.
bool ShownBeyondSphere(const CandidateScore& c, const StructureFactor& factor, bool one_placement,
                       const TraceOptions& trace_options);

// Whether `sphere`, the pattern fixed on the sphere that competes with the effects, explains the
// residual better than a candidate scored delta_bic, or about as well (within ambiguity_bic): then
// a machine effect is the claim that must be shown.
inline bool PatternAboutAsGood(const SpherePattern& sphere, double delta_bic, const TraceOptions& trace_options) {
  return sphere.delta_bic <= -trace_options.min_delta_bic && sphere.delta_bic < delta_bic + trace_options.ambiguity_bic;
}

// The pattern fixed on the sphere that competes with the effects in a design that does not
// separate the form: BestSpherePattern() of the current residual, or, with setups whose form is
// their own (unknown orientation, another sphere), the same choice among the harmonics of
// degree 2..kSpherePatternDegree of each set of form that NotBeyondEachSetupsPattern() takes.
// Each setup's form is then its own pattern: one common to them leaves what differs between
// their forms to an effect of the machine.
SpherePattern CompetingSpherePattern(const Readings& data, const CalibrationOptions& options,
                                     const TracedFit& current);

// With setups whose form is their own (unknown orientation, another sphere) in a design that does
// not separate the form: the admissible candidates of the time in `tried` whose functions, the
// powers of tau of their components, do not lower the linearised BIC by min_delta_bic beside a
// pattern fixed on the sphere for each set of form (spherical harmonics of degree
// 2..kSpherePatternDegree, one set for the setups of known orientation, one for each other set).
// Within a setup the time of a reading is a function of its direction (the scan order), another
// one in each setup, so a drift takes what differs between the setups' forms, which no pattern
// common to them explains. Each goes into *refused, with a note and, once per candidate, an
// ambiguity with that pattern in r.ambiguous.
void NotBeyondEachSetupsPattern(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                                const TraceOptions& trace_options, Tried& tried, TraceResult& r,
                                std::set<Effect>* refused);

// The measurement that separates effect e from a form of the sphere when the sphere was measured
// in one placement.
std::string SeparateFromForm(Effect e);

// Whether the structure test of the variable effect e follows (time or probe reading) is significant.
bool ShownByItsVariable(Effect e, const ResidualStructure& structure, const TraceOptions& trace_options);

// The structure the residual `s` still shows (its groups significant at structure_p), in words.
std::vector<Unexplained> RemainingStructure(const ResidualStructure& s, const TraceOptions& trace_options);

// CrossValidatedRms() on the readings of `data`: the RMS [um] of each fold's readings predicted by
// `model` fitted from `start` to the other folds.
double CrossValidated(const Readings& data, const CalibrationOptions& options, const EffectModel& model,
                      const EffectFitStart& start, int folds, std::uint64_t seed);

// Each reading's error [mm] when its setup is predicted from the others (LeaveOneSetupOutRms()),
// what the transfer test judges by; NaN for a reading not predicted, or predicted by a fit of the
// others that does not determine the model (DeterminedWithout()), whose setup goes into
// `not_judged` when given; empty with fewer than two setups.
std::vector<double> LeaveOneSetupOutErrors(const Readings& data, const CalibrationOptions& options,
                                           const EffectFit& fit, std::set<int>* not_judged = nullptr);

// The rms [um] of the finite `errors_mm`; NaN when none is.
double RmsUmOf(const std::vector<double>& errors_mm);

// Student's t of the mean of e_with^2 - e_without^2 over the readings both predict: how clearly
// the model with a candidate predicts the setups left out worse (> 0) or better (< 0) than the
// model without it. The readings of one setup are not independent (a misprediction is smooth over
// the setup), so a clearly worse prediction must also be worse in every setup predicted: 0 when
// one setup is predicted better. NaN when fewer than two readings are predicted by both.
double PairedTransferT(const std::vector<double>& with_mm, const std::vector<double>& without_mm,
                       const PointsData& points);

// The transfer test of candidate c fitted as `fit` beside `current`: c->loso_rms_um and c->loso_t
// (PairedTransferT() against current's errors), with two or more setups and only for a candidate
// whose cross-validated RMS is below current's (it costs a fit per setup).
void TransferTest(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                  const EffectFit& fit, CandidateScore* c);

// Each effect of `todo` added to `current`, fitted and scored. The candidates are independent:
// they are scored on up to trace_options.threads threads, each writing only its own slot, so the result
// does not depend on the number of threads.
Tried ScoreCandidates(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                      const std::vector<Effect>& todo, int round, const TraceOptions& trace_options);

// Whether a candidate may be added to `current`: a term with something to fit, every parameter
// determined, a BIC lower by trace_options.min_delta_bic, a lower cross-validated RMS, and, with two or
// more setups, not Untransferred().
bool Admissible(const CandidateScore& c, const TracedFit& current, const TraceOptions& trace_options);

// Whether candidate i of `tried` is a rival of the round's best, `best`: admissible, and within
// ambiguity_bic of it or confounded with it by the design (ConfoundedByDesign()).
bool Rival(const Readings& data, const CalibrationOptions& options, const TracedFit& current, const Tried& tried,
           std::size_t i, std::size_t best, const TraceOptions& trace_options, bool* close = nullptr);

// The ambiguities of the effect chosen in a round: the other admissible candidates that scored
// almost as well or that the design cannot tell from it, and the sphere's form where it explains
// the same change of the residual.
void ChosenAmbiguities(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                       const Tried& tried, std::size_t best, const SpherePattern& sphere, bool form_better,
                       bool form_separable, const TraceOptions& trace_options, CandidateScore& chosen,
                       std::vector<Ambiguity>* ambiguous);

// With a design that separates the form: whether candidate c still lowers the extended BIC by
// min_delta_bic with the form at the highest degree searched in the model, as the time and probe
// effects must beyond a pattern in one placement (ShownBeyondSphere()). A candidate whose signal a
// form of some degree explains as well turns with the sphere in this design: a probe polynomial,
// for one, when the eccentricity points the same way on the sphere's body in every setup. `full`
// is the current model with that form (fitted once per round); *delta_ebic gets the candidate's
// score beside it (NaN where it is not separable from that form).
bool ShownBeyondForm(const Readings& data, const CalibrationOptions& options, const CandidateScore& c,
                     const EffectFit& full, const TraceOptions& trace_options, double* delta_ebic);

// With the form in `current`'s model below sel->degree_limit: what the degrees above could hold,
// per group, from the model fitted with the form of degrees 2..degree_limit (FormSelection::higher_rms_um).
void HigherDegrees(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   FormSelection* sel);

// The current model with the form of degrees 2..limit (its start: the current fit's).
EffectFit FullForm(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   const FormSelection& sel);

// The set of two or more candidates a round adds instead of its best single one (the search over
// combinations, trace_combinations.cpp): tried when the best, tried[best], has rivals (Rival()).
// Sets of the round's eligible candidates (`eligible`, indices into `tried`) are fitted, a pair
// from each rival and the best, then a beam of the best sets grown by one, up to `max_size`
// members. A set is scored by the extended BIC charged for the search among sets (each term's
// SearchPenalty() and SubsetSearchPenalty(P, k) - SubsetSearchPenalty(P, 1), P the candidates
// scored), and qualifies when every member is needed (the set lower than each of its subsets by
// min_delta_bic), it is Admissible() with a cross-validated RMS below its subsets' too, and
// the others, added first, could each be a round's choice beside the round's pattern on the
// sphere (`sphere`, the competitor of a design that does not separate the form), and the last
// member passes what a later round would ask of it beside such a pattern or beside the form
// (`form`), in some order of the members. The set that qualifies with the lowest score replaces
// the single when neither it nor a set within ambiguity_bic of it holds the single (those are left
// to the next rounds) and it scores lower by ambiguity_bic, or, within ambiguity_bic either way,
// keeps fewer components.
// Empty members: the single stays.
struct ChosenSet {
  std::vector<std::size_t> members;  // indices into `tried`, in the order of the fit's terms
  EffectFit fit;
  double delta_bic = std::numeric_limits<double>::quiet_NaN();
  int components = 0;
  // With no set chosen: a set that qualifies and scores about as well as the single (within
  // ambiguity_bic), not chosen because it keeps more components; empty when there is none.
  std::vector<std::size_t> about_equal;
  double about_equal_delta_bic = std::numeric_limits<double>::quiet_NaN();
  int about_equal_components = 0;
};
ChosenSet BestCombination(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                          const Tried& tried, std::size_t best, const std::vector<std::size_t>& eligible,
                          const FormSelection& form, const SpherePattern& sphere, int max_size,
                          const TraceOptions& trace_options);

// A set of candidates (indices into `tried`, scored set_delta_bic with set_components) and the
// round's best single candidate that scored about as well: the ambiguity between them, the set on
// the chosen side when set_chosen. The advice names what separates each member from the single.
Ambiguity SetAgainstSingle(const Tried& tried, const std::vector<std::size_t>& set, double set_delta_bic,
                           int set_components, std::size_t single, bool set_chosen);

// Whether effect e was held back in this trace (TraceOptions::hold_confounded).
bool IsHeld(const TraceResult& r, Effect e);

// With TraceOptions::hold_confounded: whether the candidate `c` just chosen is confounded with
// another library effect (an ambiguity of r.ambiguous from `first_new` on names one). Then neither
// is added: both are held back from later rounds (a third effect chosen later is still judged
// against them, for they are scored every round), the ambiguities say so, and what else was noted
// of the chosen effect (its share that is a pattern on the sphere) is dropped with it.
bool HoldConfounded(std::size_t first_new, CandidateScore& c, TraceResult& r);

// One forward round: every effect of `pool` not yet in the model scored against `current`; the
// best admissible one is added, or a set of up to `max_set` that explains the residual better
// (BestCombination()) (true), or none is and the search ends (false). The round's scores and
// ambiguities go into `r`.
bool ForwardRound(const Readings& data, const CalibrationOptions& options, const std::vector<Effect>& pool, int round,
                  int max_set, const TraceOptions& trace_options, TracedFit& current, TraceResult& r);

// Backward: an effect that the final model no longer needs (the BIC without it is less than
// min_delta_bic higher) is removed, the least needed first, and the rest refitted.
void RemoveUnneeded(const Readings& data, const CalibrationOptions& options, const TraceOptions& trace_options,
                    TracedFit& current, TraceResult& r);

}  // namespace sph::internal

#endif  // SPH_SRC_SELECT_TRACE_STEPS_HPP_
