// What a calibration is told about its parameters beyond the readings: a parameter held at a value
// (a gauge block's d'), a Gaussian prior from an independent measurement (an autocollimator's
// alpha). sph_calibrate's --fix and --prior and a points file's header fields "fix" and "prior"
// write them alike, with the unit in the name:
//
//   fix:   NAME            held where the fit starts (the seven errors: zero)
//          NAME_UNIT=VALUE held at VALUE, e.g. d_prime_mm=-0.062
//   prior: NAME_UNIT=VALUE,U   VALUE with standard uncertainty U (k = 1), e.g. alpha_deg=0.02,0.0005
//
// NAME is one of the seven errors (alpha, a, beta, b, epsilon, c, d_prime) or a parameter of a
// library effect (theta_encoder.c2, probe_drift.t1, theta_radial_motion.x_c2, ...); UNIT is deg,
// arcsec or urad for an angle, mm or um for a length. A header field holds several, separated by
// spaces: "# prior: alpha_deg=0.02,0.0005 theta_encoder.c2_arcsec=6,1".
#ifndef SPH_IO_PARAMETER_SETTINGS_HPP_
#define SPH_IO_PARAMETER_SETTINGS_HPP_

#include <optional>
#include <string>
#include <vector>

#include "sph/model/scms_model.hpp"

namespace sph {

/// A parameter held at a value instead of fitted.
struct FixedParameter {
  std::string name;             ///< "d_prime", "theta_encoder.c2"
  std::optional<double> value;  ///< internal units (rad, mm); none: held where the fit starts
};

/// A Gaussian prior on a parameter: an independent measurement of it.
struct ParameterPrior {
  std::string name;
  double value = 0.0;  ///< internal units (rad, mm)
  double u = 0.0;      ///< its standard uncertainty (k = 1), internal units, > 0
};

/// Whether a calibration can have a parameter `name` (one of the seven errors, or a parameter of a
/// library effect), and whether it is an angle or a length.
std::optional<Quantity> ParameterQuantity(const std::string& name);

/// One "fix" entry; throws sph::Error "<what>: <problem>" (what: "--fix d_prime_mm=x",
/// "points.txt:4: fix").
FixedParameter ParseFixedParameter(const std::string& text, const std::string& what);

/// One "prior" entry; throws as ParseFixedParameter().
ParameterPrior ParseParameterPrior(const std::string& text, const std::string& what);

/// A header field's entries (separated by spaces), each parsed; `what` names the field.
std::vector<FixedParameter> ParseFixedParameters(const std::string& value, const std::string& what);
std::vector<ParameterPrior> ParseParameterPriors(const std::string& value, const std::string& what);

/// `name` as an entry writes it: "d_prime", with a value "d_prime_mm=-0.062" (report units: deg or
/// arcsec as the parameter is reported, mm or um).
std::string FixedParameterText(const FixedParameter& f);
std::string ParameterPriorText(const ParameterPrior& p);

}  // namespace sph

#endif  // SPH_IO_PARAMETER_SETTINGS_HPP_
