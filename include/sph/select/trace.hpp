// Tracing the residual: what the seven-error fit leaves, traced to the effects of the library
// (sph/model/effect_terms.hpp) that the model lacks, with the sphere's own form fitted where the
// design separates it from the machine (TraceResidual()); or a given list of effects fitted without
// selection (FitFixedEffects()).
//
// Each round fits every candidate effect beside the current model, keeps its separable and
// significant components, scores it by an extended BIC, the cross-validated rms and, with two or
// more setups, the transfer between setups, weighs it against a pattern fixed on the sphere (or,
// with the form separable, against the form of the highest degree searched), and adds the best one
// that qualifies; ambiguities are reported with the measurement that would separate them. The rules
// and every threshold of TraceOptions: docs/method/tracing-the-residual.md; the form:
// docs/method/form-separation.md.
//
// Units: the fits in rad and mm; the results' *_um fields in um. Candidates are scored in parallel;
// the result does not depend on the number of threads.
#ifndef SPH_SELECT_TRACE_HPP_
#define SPH_SELECT_TRACE_HPP_

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sph/calib/effect_fit.hpp"
#include "sph/calib/error_curves.hpp"
#include "sph/select/residual_structure.hpp"

namespace sph {

struct TraceOptions {
  std::vector<Effect> candidates;  ///< effects to try; empty: the whole library
  /// Highest harmonic order searched of the harmonic effects of Theta and of Phi; 0: chosen by the
  /// data on that axis: 4, or one above the highest of the seven-error residual's own harmonics of
  /// that axis that is significant (p below structure_p shared among the orders the analysis
  /// tests: 8 of theta, 6 of phi; an error of order k shows at k +- 1 through the eccentricity),
  /// at most what the pattern resolves (PatternOrders()). Which orders up to it an effect keeps is
  /// also the data's choice: components that are not separable or not significant are left out,
  /// and the extended BIC charges the choice among all those searched.
  HarmonicOrders harmonics{0, 0};
  int drift_order = 2;             ///< highest power of time of probe_drift
  int folds = 5;                   ///< cross-validation folds
  std::uint64_t seed = 1;          ///< of the fold assignment
  double min_delta_bic = 10.0;     ///< an effect is added only when it lowers the BIC by at least this
  double ambiguity_bic = 10.0;     ///< candidates whose BICs differ by less are "about equal"
  double max_vif = 1e4;            ///< components less separable than this are left out
  double min_t = 3.0;              ///< components with |value| / std below this are left out
  int max_effects = 4;             ///< at most this many effects are added
  /// When the effect a round would add cannot be told from another library effect (their BICs
  /// within ambiguity_bic, or the design confounds their terms): false, add the one that explains
  /// more and name the other as ambiguous; true, add neither, hold both back from later rounds
  /// and report them as two explanations (the split is not presented as known; the residual they
  /// explain stays uncompensated). A round that holds back counts among max_effects.
  bool hold_confounded = false;
  int threads = 0;                 ///< candidates scored in parallel; 0: one per hardware thread
  double structure_p = 1e-3;       ///< remaining structure with a p-value below this is reported
  /// An added effect whose signal is at least this much a pattern fixed on the sphere is reported
  /// as ambiguous with the sphere's own form error.
  double max_sphere_fraction = 0.5;
  /// Highest degree of the sphere's form fitted when the design separates it
  /// (docs/method/form-separation.md); below 2: the form is never fitted. Bounded by what the
  /// pattern resolves.
  int form_degree_max = 8;
  /// Where the Phi axis pivots when it tilts, along it from the Phi frame's origin [mm]
  /// (EffectModel::phi_wobble_pivot_mm): a constant of the machine's drawing, never fitted.
  double phi_wobble_pivot_mm = 0.0;
  /// The probe's measuring range, readings 0 to it [mm] (the points file's probe_range_mm): the
  /// probe terms are expressed at its ends (WithProbeRange()); empty: at the ends of the readings.
  std::optional<double> probe_range_mm;
  /// Called with (round, candidates scored, candidates of the round) as each candidate is scored
  /// (from the scoring threads, one at a time).
  std::function<void(int round, int done, int total)> progress;
};

/// One candidate tried in one round: an effect of the library, or (sphere_form) the sphere's form
/// that competes with them: in one placement a pattern fixed on the sphere, with a design that
/// separates the form its next degrees (added: the degree was raised).
struct CandidateScore {
  Effect effect = Effect::kThetaEncoder;
  bool sphere_form = false;  ///< the competitor, not an effect
  /// "sphere_form" or the effect's id.
  std::string Id() const { return sphere_form ? "sphere_form" : InfoOf(effect).id; }
  int round = 0;    ///< 1 for the first round, ...
  EffectTerm term;  ///< the components kept (empty: nothing the data determine)
  /// Extended BIC with it minus without: the BIC's change plus SubsetSearchPenalty() of the
  /// components kept of those searched; NaN when nothing of it was left to fit.
  double delta_bic = 0.0;
  double rms_um = 0.0;      ///< fit RMS with it
  double cv_rms_um = 0.0;   ///< cross-validated RMS with it; NaN when the BIC does not admit it (not needed, so not
                            ///< computed) and for sphere_form (not fitted)
  /// Leave-one-setup-out RMS with it (TracedFit::loso_rms_um), the transfer test; NaN when not
  /// computed: one setup, or the BIC and the cross-validated RMS do not admit it.
  double loso_rms_um = std::numeric_limits<double>::quiet_NaN();
  /// How clearly it predicts the setups left out worse than the model without it: Student's t of
  /// the mean of the squared prediction errors with it minus without, over the readings (NaN as
  /// loso_rms_um). Above TraceOptions::min_t it is not added: it does not transfer.
  double loso_t = std::numeric_limits<double>::quiet_NaN();
  bool determined = false;  ///< every parameter of the model with it is determined
  bool added = false;
  /// Held back, never added: it cannot be told from another effect (TraceOptions::hold_confounded).
  bool held = false;
  double sphere_fraction = 0.0;  ///< of the added effect's signal (SpherePatternFraction); 0 when not added
  std::string note;              ///< why it was not added, or what was left out
  /// Added in a set of effects chosen together (the search over combinations): the set's ids, its
  /// extended BIC (charged for the search among sets), and the round's best single candidate it
  /// was chosen over with that one's; empty and NaN when added alone or not added.
  std::vector<std::string> set;
  double set_delta_bic = std::numeric_limits<double>::quiet_NaN();
  std::string set_over;
  double set_over_delta_bic = std::numeric_limits<double>::quiet_NaN();
};

/// Two explanations of the residual that the data cannot tell apart: an effect added and another
/// candidate whose BIC is about as good, or the form error of the reference sphere ("sphere_form")
/// when most of what the added effect explains is a pattern fixed on the sphere. With chosen
/// "sphere_form", nothing was added: a pattern on the sphere explains more than `other`, an
/// effect of the time or the probe reading that its own variable shows, but no more than a form.
struct Ambiguity {
  std::string chosen, other;  ///< effect ids, or "sphere_form"
  double delta_bic_chosen = 0.0;
  double delta_bic_other = 0.0;  ///< NaN for a pattern fixed on the sphere in one placement
  double sphere_fraction = 0.0;  ///< share of the chosen effect's signal that is a pattern fixed on the sphere
  std::string separate_by;       ///< the measurement that would tell them apart
  double chosen_rms_um = std::numeric_limits<double>::quiet_NaN();  ///< what the chosen one explains (RMS)
  double other_rms_um = std::numeric_limits<double>::quiet_NaN();   ///< what the other explains (RMS)
  /// "sphere_form" is the form of a design that separates it, at the highest degree searched (it
  /// turns with the sphere), not a pattern fixed on the sphere in one placement.
  bool form_turns_with_sphere = false;
  /// For two effects: separate_by checked on this design, from its Jacobian (no fit), in words:
  /// which placement of the sphere added to the file's would tell them apart, or that none of
  /// those tried would; empty for the form.
  std::string checked = "";
  /// For two effects: neither was added, for the design cannot tell them apart and the trace does
  /// not pick one (TraceOptions::hold_confounded).
  bool neither_added = false;
  /// For two effects: named because the design cannot tell them apart (a variance inflation of
  /// their terms fitted together above 100) though the other scored clearly worse, rather than
  /// because both scored about as well.
  bool by_design = false;
  /// When a side is a set of effects that the search over sets fitted together: its effect ids
  /// (`chosen` or `other` then joins them with " + "); empty for a single effect or the form.
  std::vector<std::string> chosen_set = {}, other_set = {};
  int chosen_components = 0, other_components = 0;  ///< for a set against a single: components of each
};

/// How the trace treated the sphere's form.
struct FormSelection {
  bool separable = false;  ///< the design separates the form from the machine
  /// The reference sphere's form was given (CalibrationOptions::form_prior): it is in the model
  /// from the start, at the prior's degree, as known within the prior's covariance, and no
  /// pattern fixed on the sphere competes with the effects (`separable` is then true as well).
  bool known = false;
  std::string design;      ///< why or why not, in words
  int degree_max = 0;      ///< the degree L fitted (0: no form in the final model)
  int degree_limit = 0;    ///< the highest degree searched (what the pattern resolves, at most form_degree_max)
  /// What the design cannot tell apart from the seven errors, the centres and the candidate
  /// effects (IdentifyForm(), before any fit), in words.
  std::vector<std::string> confounded;
  /// Per degree searched, in the last search: extended BIC of the model with the form of degrees
  /// 2..L minus that without a form.
  std::vector<std::pair<int, double>> delta_ebic;
  /// Per group of the final model's form, the degrees above degree_max up to degree_limit fitted
  /// beside it: their RMS with the noise's share taken out and its standard uncertainty [um]
  /// (CorrectedFormRms()); empty when the form was fitted at degree_limit or not at all.
  std::vector<std::pair<double, double>> higher_rms_um;
};

/// Structure left after the final model.
struct Unexplained {
  std::string variable;     ///< what it follows (StructureGroup::variable)
  std::string description;  ///< in words
  double rms_um = 0.0;      ///< RMS of the part that group explains
  double p_value = 1.0;
};

/// The fit, its residual analysis and its cross-validated RMS.
struct TracedFit {
  EffectFit fit;
  /// The reading of each sample at which the fit's residual vanishes (ExpectedReadings()): where
  /// the residual analyses evaluate the Jacobian, the functions of r and `directions`.
  std::vector<double> expected_r_mm;
  std::vector<Eigen::Vector3d> directions;  ///< from the fitted centre to each probed point (unit)
  StructureFactor factor;                   ///< what the residual analyses of this fit are computed from
  ResidualStructure structure;
  double cv_rms_um = 0.0;
  /// The transfer test of a file with two or more setups: each setup of known orientation predicted
  /// by the model fitted to the others, with only its own centre (and a drift over its own time)
  /// refitted; the rms over those
  /// setups' readings [um]. A form that turns with the sphere transfers, a form mistaken for a
  /// machine error does not. Only the setups predicted by a model that the others determine count
  /// (loso_not_judged); NaN with fewer than two setups or when none is (LeaveOneSetupOutRms()): the
  /// transfer cannot be judged on this design.
  double loso_rms_um = std::numeric_limits<double>::quiet_NaN();
  /// The setups left out whose prediction came from a fit of the others that does not determine
  /// the model (its effects' or form's standard uncertainties, a drift's aside, more than 10 times
  /// those of the fit of all): not judged, and not in loso_rms_um.
  std::vector<int> loso_not_judged;
  /// Each reading's error in that test [mm], NaN where not predicted and where the other setups
  /// do not determine the model (what the selection judges by); empty with one setup.
  std::vector<double> loso_errors_mm;
};

struct TraceResult {
  TracedFit before;           ///< seven errors only
  TracedFit after;            ///< with the effects added
  std::vector<Effect> added;  ///< in the order added (less those removed); the stated ones first
  /// The effects a fixed value or a prior of CalibrationOptions names a parameter of: a statement
  /// that they exist, so the model holds them from the start (their default terms, with the named
  /// components), never removed (they are in `added` too).
  std::vector<Effect> stated;
  /// Effects held back as confounded with another (TraceOptions::hold_confounded).
  std::vector<Effect> held;
  /// Effects removed by the backward step, with the BIC without them minus with them.
  std::vector<std::pair<Effect, double>> removed;
  std::vector<CandidateScore> candidates;  ///< every candidate of every round
  std::vector<Ambiguity> ambiguous;
  std::vector<Unexplained> unexplained;
  FormSelection form;
  HarmonicOrders harmonics;  ///< the highest harmonic orders searched (TraceOptions::harmonics resolved)
  /// The error curves of the final model's effects of an axis angle, with their 95 % bands
  /// (ErrorCurvesOf(), over all the readings' angles).
  std::vector<ErrorCurve> curves;
};

/// The highest harmonic order the pattern of `points` resolves on each axis: with n distinct
/// readings of the angle (to 1e-6 deg, a full turn apart counted once), the harmonics of orders
/// k <= (n - 1) / 2 are independent functions on them, and higher ones alias onto those; at most
/// kMaxEffectHarmonic (a scan with a reading per SYNC has thousands of distinct angles).
HarmonicOrders PatternOrders(const PointsData& points);

/// The highest degree of the sphere's form that a trace of `points` would fit: what the pattern
/// resolves, at most trace_options.form_degree_max, and no more than the cross-validation's folds
/// can fit beside the seven errors and the centres (FormSelection::degree_limit).
int FormDegreeLimit(const PointsData& points, const TraceOptions& trace_options);

/// Traces the residual of `points` (docs/method/tracing-the-residual.md). `base` is the seven-error
/// calibration of the same points and options; the readings it left out as outliers are left out of the
/// selection and judged again under the final model. The effect reference is that of all the
/// readings (EffectReferenceOf).
TraceResult TraceResidual(const PointsData& points, const CalibrationOptions& options, const CalibrationResult& base,
                          TraceOptions trace_options);

/// With options.form_prior the reference sphere's form is in the model from the start, at the
/// prior's terms and informed by it (FormSelection::known), and the effects are judged beside it.
/// An effect a fixed value or a prior of options names a parameter of is in the model from the
/// start too (TraceResult::stated). Traces as above otherwise.
///
/// Fits a fixed model: the seven errors and the default terms of `effects` (no selection, nothing
/// left out), with the same residual analysis and cross-validation (and the known form of
/// options.form_prior, when given); `after` holds the fit.
TraceResult FitFixedEffects(const PointsData& points, const CalibrationOptions& options, const CalibrationResult& base,
                            const std::vector<Effect>& effects, TraceOptions trace_options);

/// The effects a fixed value or a prior of `options` names a parameter of, in the order named.
std::vector<Effect> StatedEffects(const CalibrationOptions& options);

/// Fits a given model as FitFixedEffects() does: the seven errors, `terms` as they are (their
/// components, none added or left out) and the sphere's form of `form_terms` (none when empty; with
/// options.form_prior the known form in its place). `probe_reference`, when given, normalises the
/// probe terms (its r_ref_mm and r_half_range_mm; the run's times and fit range stay the
/// readings'): a model read from a calibration file, fitted to other readings so that its
/// parameters are the same quantities as the file's.
TraceResult FitGivenModel(const PointsData& points, const CalibrationOptions& options, const CalibrationResult& base,
                          const std::vector<EffectTerm>& terms, const std::vector<FormTerm>& form_terms,
                          TraceOptions trace_options, const EffectReference* probe_reference = nullptr);

/// The leave-one-setup-out RMS [um] of `fit` (a fit of `points`, TracedFit::loso_rms_um): for each
/// setup of known orientation, `fit`'s model is fitted to the other setups' readings, from `fit`,
/// and the setup's readings are predicted with only its centre, and the components of a term of
/// the time (a drift, which says nothing of another part of the run), refitted (Gauss-Newton). A setup
/// of unknown orientation is not predicted (its form is its own), but its readings take part in
/// the other fits; nor is a setup without which the others cannot be fitted (too few readings),
/// nor one whose others do not determine the model (TracedFit::loso_not_judged). NaN when no setup
/// is predicted (one setup, or none of known orientation, or none by a determined model).
double LeaveOneSetupOutRms(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit);

/// The cross-validated RMS [um] of `model` on `points`: `folds` random folds (seeded), each fitted
/// from `start` without its points and then predicted.
double CrossValidatedRms(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                         const EffectFitStart& start, int folds, std::uint64_t seed);

}  // namespace sph

#endif  // SPH_SELECT_TRACE_HPP_
