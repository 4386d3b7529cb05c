// A Digital Calibration Certificate (DCC): the XML document of PTB's DCC schema 3.1.2, its
// quantities in the D-SI format 2.1.0 (si:real, SI units, si:expandedUnc), that a customer's
// software reads. What goes where, and how to validate it: docs/dcc.md.
//
// The administrative data (the laboratory, the customer, the responsible persons, the items, the
// certificate's identifier and dates) come from a laboratory's settings file and the points file's
// header, whose keys are the same (kDccKeys; the header's win, the settings hold the laboratory's
// defaults); the header's `started` (sph_acquired's) dates the calibration when no
// `performance_date` is given, and its `device_*` lines name the SCMS's devices. The results come
// from the report of the run (the calibration's or the measurement's own writer): each value and
// its expanded uncertainty in SI units, rounded as GUM 7.2.6 states them (sph/stats/rounding.hpp).
#ifndef SPH_IO_DCC_HPP_
#define SPH_IO_DCC_HPP_

#include <istream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace sph::dcc {

/// What a certificate is of: a calibration of the SCMS (the item) with a reference sphere (the
/// measuring equipment), or a measurement of a sphere (the item) with the SCMS.
enum class Kind { kCalibration, kMeasurement };

/// A key of the settings file and the points header.
struct KeyInfo {
  const char* key;
  const char* what;
  bool calibration;  ///< required for a calibration's certificate
  bool measurement;  ///< required for a measurement's
  bool repeated;     ///< may be given more than once (each a further entry)
};
/// Every key, in the order of the settings file's page (docs/dcc.md).
extern const std::vector<KeyInfo> kDccKeys;

/// One value of the settings: its key, its value and where it was given ("lab.txt:3").
struct Field {
  std::string key, value, where;
};

/// A laboratory's settings: `key: value` lines, `#` comments and blank lines.
struct Settings {
  std::vector<Field> fields;
};

/// Reads a settings file. Throws sph::Error naming the file and line for a line that is not
/// `key: value`, a key not in kDccKeys, a key given twice that is not repeated, or a value that
/// its key does not take (a date not YYYY-MM-DD, a country not two capitals, a performance
/// location the schema does not know).
Settings ReadSettings(const std::string& path);
/// The same from a stream, `source` naming it in messages.
Settings ParseSettings(std::istream& in, const std::string& source);

/// A value of a result or a condition: a number in an SI unit with its expanded uncertainty, or a
/// text (`value` NaN).
struct Quantity {
  std::string id;    ///< the XML id: the report's key it comes from ("parameters.alpha")
  std::string name;  ///< "alpha (ISO 230-1: EA0B)"
  std::string description;
  double value = std::numeric_limits<double>::quiet_NaN();
  std::string unit;  ///< D-SI: "\\radian", "\\metre", "\\degreeCelsius", "\\one"
  /// The expanded uncertainty U = k u in `unit`; NaN: none stated (the value is printed to 6
  /// significant digits); 0: an exact value.
  double uncertainty = std::numeric_limits<double>::quiet_NaN();
  double coverage_factor = 2.0;
  double coverage_probability = 0.9545;
  std::string text;  ///< when value is NaN: the quantity as words
};

/// A report's value in `report_unit` (deg, urad, arcsec, mm, um, nm; any other: a number of unit
/// one) with its expanded uncertainty U in the same unit (NaN: none), in SI units (rad, m).
Quantity InSi(const std::string& id, const std::string& name, double value, const std::string& report_unit,
              double U = std::numeric_limits<double>::quiet_NaN(), double coverage_factor = 2.0,
              double coverage_probability = 0.9545);

/// The coverage probability of k for a normal distribution (2: 0.9545), and the k of a probability.
double ProbabilityOfK(double k);
double KOfProbability(double p);

/// One result of the measurement: a name and its quantities.
struct Result {
  std::string name, description;
  std::vector<Quantity> quantities;
};

/// A method the results come from.
struct Method {
  std::string name, description;
  std::vector<std::string> norms;       ///< "JCGM 100:2008"
  std::vector<std::string> references;  ///< a publication
};

/// What a run gives its certificate.
struct Content {
  Kind kind = Kind::kCalibration;
  std::string software, release;  ///< "sph_calibrate", "0.1.0"
  std::string title;              ///< the measurement result's name
  std::string description;
  std::vector<Method> methods;
  std::vector<Quantity> conditions;  ///< the influence conditions, one quantity each
  std::vector<Result> results;
  /// The points file's header fields (PointsHeader::metadata): keys of kDccKeys, `started`,
  /// `device_*`.
  std::vector<std::pair<std::string, std::string>> header;
  double duration_s = 0.0;       ///< from the first reading to the last (t_s), for the end date
  std::string points_file;       ///< as the report names it
  std::string calibration_file;  ///< a measurement's: the calibration file it was compensated with
  /// A measurement's: the calibration file's "source" (its points file's header among it).
  std::vector<std::pair<std::string, std::string>> calibration_source;
};

/// The certificate as an XML document (UTF-8). Throws sph::Error when the settings and the header
/// together lack a required key, naming every key missing, what it is and where it may be given.
std::string WriteCertificate(const Content& content, const Settings& settings);

}  // namespace sph::dcc

#endif  // SPH_IO_DCC_HPP_
