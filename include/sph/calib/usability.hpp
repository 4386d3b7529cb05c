// Whether a calibration can be used to compensate the machine, judged as a metrologist would, and
// why not. A fit that converged with every parameter determined by its own scatter
// (CalibrationResult::Usable()) is not enough: a parameter can be determined to the nanometre by
// the points and still be uncertain by millimetres through what the fit takes as exact (R0 at an
// uncertain temperature), or fit the points only because a wrong radius or probe offset was given.
//
// A calibration is usable when
//   - the solver converged;
//   - every parameter of the fit is determined: its standard uncertainty from the fit (Type A), as
//     a displacement of the probed point (angles times their lever arm), is at most max_std_um;
//   - with an uncertainty budget, every parameter the calibration applies (the seven errors, the
//     effects, the sphere's form; not the centres, which belong to the measurement) has a combined
//     standard uncertainty u_c (Type A and B) as a displacement of at most max_std_um; the reason
//     names U = k u_c and the input that contributes most;
//   - the zero error d' is small against the set-up it corrects: |d'| at most a tenth of the
//     smallest sphere's radius (with the nominal d the points lie on a sphere of radius about
//     R0 - d': a |d'| of that size says the stated R0 or d does not describe the set-up; a real
//     zero error that large is taken into d), and at most the probe's measuring range when stated;
//   - every error and effect lies within what a calibration file holds (an error of the machine,
//     not another machine: kScmsParamInfo's bounds, |d'| below d; kMaxEffectArcsec, kMaxEffectUm);
//   - the readings reject none of the lab's statements (sph/calib/statements.hpp) that the user did
//     not accept against them;
//   - the requirement (UsabilityRequirement): the lab's, when stated (a target expanded
//     uncertainty U per parameter, or max_std_um given), else the default that the set-up can
//     reach: each of the seven errors' standard uncertainty from the seven-error fit of the
//     readings, as a displacement, at most twice what the reference pattern predicts for this
//     set-up at that fit's noise (ReferenceUncertaintyUm()): the pattern and the readings determine
//     the machine at least half as well as the reference. The verdict says which was applied.
// When it is not, the context's likely cause (what the readings show was misread) ends the reasons.
#ifndef SPH_CALIB_USABILITY_HPP_
#define SPH_CALIB_USABILITY_HPP_

#include <string>
#include <vector>

#include "sph/calib/report.hpp"

namespace sph {

/// A target expanded uncertainty of one parameter, stated by the lab (--target-u).
struct TargetUncertainty {
  std::string name;  ///< as FixedParameter::name: "alpha", "theta_encoder.c2"
  double U = 0.0;    ///< its largest expanded uncertainty U = k u_c (k as the budget's), internal units
  std::string text;  ///< as the lab wrote it ("beta_urad=300"); empty: written from name and U
};

/// What "usable" is judged against beyond the fit's own checks (see the file comment).
struct UsabilityRequirement {
  /// The lab's targets; when any is given, they are the requirement.
  std::vector<TargetUncertainty> target_u;
  /// max_std_um was stated (--max-std-um): every standard uncertainty within it is the requirement.
  bool max_std_stated = false;
  /// The default's reference: per error of the seven, what the reference pattern predicts at this
  /// set-up [um] (ReferenceUncertaintyUm()); empty: not computed (no default judged).
  std::vector<double> reference_um;
  double reference_noise_um = 0.0;  ///< the noise the reference was predicted at [um]
  /// Per error of the seven, its standard uncertainty as a displacement from the seven-error fit of
  /// the same readings [um]: what the pattern and the readings determine, judged against
  /// reference_um (the effects a trace adds beside them, and their correlations, are judged by
  /// max_std_um alone).
  std::vector<double> seven_um;

  /// The requirement applied, in words (the report's verdict names it).
  std::string Text(double max_std_um) const;
};

/// The default's factor: a standard uncertainty at most this many times the reference's.
inline constexpr double kReferenceFactor = 2.0;

/// Per error of the seven, the standard uncertainty as a displacement [um] that the reference
/// pattern (the paper's: one placement of the sphere at 2 mm eccentricity, 24 x 12 readings)
/// predicts (PredictUncertainty(), sph/calib/design.hpp) for a set-up of R0 `sphere_radius_mm` and d
/// `probe_offset_mm` at the errors `geometry`, with noise `noise_um` on r.
std::vector<double> ReferenceUncertaintyUm(double sphere_radius_mm, double probe_offset_mm,
                                           const ScmsGeometry& geometry, double noise_um);

/// The judgement of a calibration and, when it is not usable, why, one reason each in words.
struct Usability {
  bool usable = true;
  std::vector<std::string> reasons;
  std::string requirement;  ///< the requirement applied, in words
};

/// Judges `result`, the calibration reported, in its context (see the file comment): ctx's radii,
/// probe offset, max_std_um, probe range and budget, and, when the trace's final fit added effects
/// or a form (ctx.trace), their values.
Usability JudgeUsability(const CalibrationResult& result, const ReportContext& ctx);

}  // namespace sph

#endif  // SPH_CALIB_USABILITY_HPP_
