// Error curves: each fitted effect that is a function of an axis angle (the encoders' positional
// deviation, the axes' error motions) as the curve over the measured range of that angle with its
// pointwise expanded uncertainty, what a certificate gives, beside the coefficients.
//
// The curve of a term's components on one axis (x or y of a two-axis effect) is
//   e(x) = sum_i p_i b_i(x) - mean over the pattern's angles of the same,   b_i = cos k x or sin k x,
// the components those the trace chose. The curve's mean is not determined: a constant of an
// encoder is a zero of its axis (beta for Phi, the sphere's azimuth for Theta), a constant of an
// error motion a centre or an offset of the probe line, all of them parameters of the seven errors
// and the centres; so every curve is given about its mean over the measured angles.
//
// Its band holds what the choice of the components leaves uncertain, not only the noise of those
// chosen. The trace keeps a component when its |t| is at least min_t: a true component can be left
// out, or one that noise made large kept, and over part of a turn the chosen components represent
// one left out only in part (a truncation). So the band averages the models the choice could have
// given: the term with every component searched that the readings separate (VIF at most max_vif,
// the least separable left out first) is fitted beside the rest of the model, and every subset of
// its components within two of the chosen ones (one or two added or left out) is fitted from it by
// the linearised problem and weighted by exp(-EBIC/2), the extended BIC by which the trace chooses
// (BIC plus SubsetSearchPenalty()). With M the weighted second moment of the subsets' coefficients
// about the chosen ones (each subset's covariance plus its offset from the chosen, squared),
//   U(x) = k sqrt(g(x)^T M g(x)),   g the basis values of the components averaged, less their mean:
// the noise of the chosen curve, what the other models would have given instead (a component left
// out, by its fitted size) and their noise, by their weights. Over less than a full turn the
// harmonics are not independent functions; the curve over the range is what is determined, and
// ErrorCurve::left_out says how much of each component searched but not chosen is, over the range,
// a combination of those chosen.
//
// Conventions: an encoder's curve is the ISO 230-2 positional deviation, actual minus indicated
// (theta_true - theta_read, as the model defines the term), its range max - min; an error motion's
// is the ISO 230-7 error motion along a fixed sensitive direction (the frame's x, y or the axis),
// its error motion value the peak to valley over the range. The once-per-turn part of a radial
// motion is the set-up's (ISO 230-7's centring error), never in the curve.
//
// Units: the curves in arcsec (angles) or um (lengths), angles of the axis in deg.
#ifndef SPH_CALIB_ERROR_CURVES_HPP_
#define SPH_CALIB_ERROR_CURVES_HPP_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/effect_fit.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph {

/// A component searched but not fitted, and how much of it, over the measured range, the
/// components fitted represent.
struct LeftOutComponent {
  std::string name;  ///< "phi_encoder.c1"
  /// 1 - |f - P f|^2 / |f|^2 over the pattern's angles, f the component's function less its mean
  /// and P the least-squares projection onto those fitted (less their means): 1, the range cannot
  /// tell it from them; 0, it is orthogonal to them.
  double represented = 0.0;
};

struct ErrorCurve {
  Effect effect = Effect::kThetaEncoder;
  int axis = 0;            ///< 0, or 1 for the y component of a two-axis effect
  std::string name;        ///< the effect's id, with ".x" or ".y" for a two-axis effect
  std::string iso_name;    ///< ISO 230's symbol of this direction: "ECC", "EXC", ...
  std::string variable;    ///< the axis angle: "theta" or "phi"
  std::string unit;        ///< "arcsec" or "um"
  std::string convention;  ///< the certificate's quantity, in words
  bool encoder = false;    ///< ISO 230-2 positional deviation (else an ISO 230-7 error motion)
  /// The measured range [deg]: the smallest arc holding every reading of the angle, from lo
  /// upwards to hi (hi may exceed 360); full_turn when no gap between the pattern's angles is
  /// more than twice an even spacing.
  double range_lo_deg = 0.0, range_hi_deg = 360.0;
  bool full_turn = true;
  double coverage_probability = 0.95;
  double coverage_factor = 2.0;  ///< k of the band (Student's t with the fit's degrees of freedom)
  /// The curve at the table's angles: the pattern's distinct angles in the range, ascending from
  /// range_lo_deg (at most kMaxCurveTableAngles; more are thinned to an even step), in [0, 360).
  std::vector<double> angle_deg, value, u95;
  /// Peak to valley of the curve over the range (ISO 230-2 range, ISO 230-7 error motion value),
  /// on a fine grid, and its expanded uncertainty linearised at the two extremes and their angles.
  double pv = 0.0, pv_u95 = 0.0, max_angle_deg = 0.0, min_angle_deg = 0.0;
  std::vector<std::string> fitted;         ///< the components fitted on this axis: "phi_encoder.c2", ...
  std::vector<LeftOutComponent> left_out;  ///< searched, not fitted
  /// The components of the models averaged for the band, on this axis (those fitted, then the
  /// others separable); the number of models and the weight of the chosen one among them. One
  /// model of weight 1: none averaged (the full fit did not converge), the band the chosen
  /// components' noise alone.
  std::vector<std::string> averaged;
  int models_averaged = 1;
  double chosen_weight = 1.0;

  /// e(x) and U(x) at any angle [deg] (the table's values are these).
  double ValueAt(double at_deg) const;
  double U95At(double at_deg) const;

  // What the curve is made of (in the curve's unit): the components, their values, covariance and
  // the mean of each basis function over the pattern's angles; the band's components, the mean of
  // their basis functions and the averaged models' second moment M about the chosen values.
  std::vector<EffectComponent> components, band_components;
  Eigen::VectorXd coefficients, basis_mean, band_basis_mean;
  Eigen::MatrixXd covariance, band_moment;

  /// The basis values at `angle_deg` less their means, of the chosen and of the band's components.
  Eigen::VectorXd Basis(double at_deg) const;
  Eigen::VectorXd BandBasis(double at_deg) const;
};

/// The most angles of a curve's table (a pattern with more distinct angles is thinned).
inline constexpr int kMaxCurveTableAngles = 73;

/// The curves of every harmonic term of `fit` (a fit with `options` of `points` less the fit's
/// outliers), one per axis of each, in term order; `searched`: the highest harmonic orders searched
/// (the components of DefaultTerm() not fitted are left_out; those of them whose VIF beside the
/// others is at most `max_vif` are in the models averaged). Needs the fit's analysis (covariance);
/// a component not determined makes the band infinite. Refits the model once for each term with
/// components left out, and again for each left out as not separable. `coverage_probability` of
/// the band, e.g. 0.95.
std::vector<ErrorCurve> ErrorCurvesOf(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                      HarmonicOrders searched, double max_vif, double coverage_probability = 0.95);

}  // namespace sph

#endif  // SPH_CALIB_ERROR_CURVES_HPP_
