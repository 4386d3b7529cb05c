// What a measurement design can tell apart, from the design alone, before any fit: the null space
// of the Jacobian of the model's residuals (the seven errors, each setup's centre, effects, the
// sphere's form) linearised over the design's readings, with unit columns. Which form terms the
// design separates from the machine (IdentifyForm()), and how far it tells the machine's effects
// apart from each other (IdentifyEffectPairs()). The machine is what the model holds: an error
// outside the effect library is not part of the judgement. What follows from it for a sphere on a
// Theta table: docs/method/form-separation.md.
#ifndef SPH_SELECT_IDENTIFIABILITY_HPP_
#define SPH_SELECT_IDENTIFIABILITY_HPP_

#include <string>
#include <vector>

#include "sph/calib/effect_fit.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/form_model.hpp"

namespace sph {

/// A combination of parameters the design cannot tell apart.
struct ConfoundedCombination {
  double relative_singular_value = 0.0;  ///< sigma_k / sigma_max of the equilibrated Jacobian
  /// Parameter names with their coefficients, displacement-equivalent (angles times R0), the
  /// largest magnitude 1, those below 0.1 left out (ObservabilityReport::weak).
  std::vector<std::pair<std::string, double>> terms;
  std::vector<FormTerm> form_terms;  ///< the form's terms among them (any group)
  std::string words;                 ///< what cannot be told from what, and why it matters
};

/// The form terms of a design that its readings separate from the machine, and those they do not.
struct FormIdentifiability {
  std::vector<FormTerm> separable;                  ///< in the order of the terms asked about
  std::vector<FormTerm> confounded;                 ///< the others
  std::vector<ConfoundedCombination> combinations;  ///< weakest first
  /// Each term's variance inflation against the determinable machine and the other form terms, in
  /// the order of the terms asked about (confounded above 1 / max_singular_value^2; +inf when
  /// reproduced exactly).
  std::vector<double> variance_inflation;
  /// The largest variance inflation (0 without form terms).
  double MaxVarianceInflation() const;
};

/// Relative singular values below this count as confounded: the variance of such a combination
/// is at least 1e4 times what the same parameters would have with independent columns.
inline constexpr double kConfoundedSingularValue = 1e-2;

/// Which of the form terms `form_terms` (shared by the setups of known orientation, one set per
/// setup of unknown orientation: FormModelOf) the readings of `points` separate from the seven
/// errors, the centres and the effects of `model` (its form is replaced), linearised at `at` (the
/// form at zero). Nothing is fitted. Throws sph::Error as FitEffects() for an unusable design.
FormIdentifiability IdentifyForm(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                                 const EffectFitStart& at, const std::vector<FormTerm>& form_terms,
                                 double max_singular_value = kConfoundedSingularValue);

/// How far two effects of a model inflate each other's variance on a design: the largest factor by
/// which the variance of a component of either grows when the other is fitted beside it, 1 / (1 -
/// rho^2) for the partial correlation rho of that component with the other effect's components
/// given the seven errors, the centres, the form and the component's own effect. The other effects
/// of the model are not in it: a pair names what cannot be told from what; an effect that is the
/// sum of two others is not judged here.
struct EffectPairInflation {
  Effect a = Effect::kThetaEncoder;
  Effect b = Effect::kThetaEncoder;
  double factor = 1.0;  ///< +inf: the design cannot tell them apart at all
};

/// Two effects count as told apart when neither inflates the variance of a component of the other
/// by more than this (a partial correlation of at most 0.995), the bound a trace also checks its
/// advice against.
inline constexpr double kSeparatedPairInflation = 100.0;

/// Which of a model's effects a design tells apart from each other.
struct EffectSeparability {
  /// Effects of which the design determines no component beside the seven errors, the centres and
  /// the form (a wobble of the Phi axis about the Phi frame's origin, for one).
  std::vector<Effect> undetermined;
  /// Every pair of the other effects, in the model's order.
  std::vector<EffectPairInflation> pairs;
};

/// How far the readings of `points` tell the effects of `model` apart from each other, beside the
/// seven errors, the centres and the form terms `form_terms` (shared by the setups of known
/// orientation, one set per other sphere or unknown orientation; none: no form), linearised at `at`
/// (effects and form at zero where it gives no values). Each effect is first reduced to the
/// components the design determines beside those (variance inflation at most 10^4 with the
/// effect alone in the model, the worst left out first), as a trace's candidate keeps them; a
/// direction of the seven errors, centres and form that the design leaves open is set aside, as in
/// IdentifyForm(). Nothing is fitted. Throws sph::Error as IdentifyForm().
EffectSeparability IdentifyEffectPairs(const PointsData& points, const CalibrationOptions& options,
                                       const EffectModel& model, const EffectFitStart& at,
                                       const std::vector<FormTerm>& form_terms);

}  // namespace sph

#endif  // SPH_SELECT_IDENTIFIABILITY_HPP_
