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
//     not another machine: kScmsParamInfo's bounds, |d'| below d; kMaxEffectArcsec, kMaxEffectUm).
// When it is not, the context's likely cause (what the readings show was misread) ends the reasons.
#ifndef SPH_CALIB_USABILITY_HPP_
#define SPH_CALIB_USABILITY_HPP_

#include <string>
#include <vector>

#include "sph/calib/report.hpp"

namespace sph {

/// The judgement of a calibration and, when it is not usable, why, one reason each in words.
struct Usability {
  bool usable = true;
  std::vector<std::string> reasons;
};

/// Judges `result`, the calibration reported, in its context (see the file comment): ctx's radii,
/// probe offset, max_std_um, probe range and budget, and, when the trace's final fit added effects
/// or a form (ctx.trace), their values.
Usability JudgeUsability(const CalibrationResult& result, const ReportContext& ctx);

}  // namespace sph

#endif  // SPH_CALIB_USABILITY_HPP_
