// The valid values of a number an option or a setting takes, and the one message that refuses
// another: "must be > 0 and <= 1000 mm, got 1e308". The apps show them in --help and check what
// is typed; the library checks the values a host program sets.
#ifndef SPH_CORE_VALID_RANGE_HPP_
#define SPH_CORE_VALID_RANGE_HPP_

#include <string>
#include <type_traits>

namespace sph {

/// Finite, between `lo` and `hi` (excluded where open), in `unit`.
struct ValidRange {
  double lo;
  double hi;
  const char* unit;  ///< "mm", "deg", "s", ...; "" for a pure number
  bool lo_open = false;
  bool hi_open = false;

  bool Contains(double v) const;
  /// "0 < x <= 1000 mm"
  std::string Text() const;
  /// "must be > 0 and <= 1000 mm, got 1e308"
  std::string Refusal(const std::string& text) const;
};

/// Checks a number parsed or set elsewhere (a part of "x,y,z", a field of an options struct):
/// returns it, or throws sph::Error "<what>: must be ..., got <text>".
double CheckedValue(double value, const ValidRange& range, const std::string& what, const std::string& text);

/// CheckedValue() of a value that has no text of its own: the message shows it in its shortest
/// exact form ("--dwell-s: must be >= 0 and <= 86400 s, got -1").
double CheckedValue(double value, const ValidRange& range, const std::string& what);

/// CheckedValue() of an integer or another arithmetic field, compared as a double.
template <typename T, typename = std::enable_if_t<std::is_arithmetic_v<T> && !std::is_same_v<T, double>>>
T CheckedValue(T value, const ValidRange& range, const std::string& what) {
  CheckedValue(static_cast<double>(value), range, what);
  return value;
}

/// The check of a typed value, for a command line's validators: empty when `text` is a finite
/// number in `range`, else the refusal that CheckedValue() gives after the name: "must be > 0 and
/// <= 1000 mm, got 1e308".
std::string RefusalOf(const std::string& text, const ValidRange& range);

/// RefusalOf() of a setting that also takes `special`, meaning `meaning`, outside the range:
/// "must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-300", as CheckedValueOr() words it.
std::string RefusalOf(const std::string& text, double special, const std::string& meaning, const ValidRange& range);

/// CheckedValue() of a setting that also takes one value of its own meaning outside the range:
/// "--heartbeat-period-s: must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-300".
double CheckedValueOr(double value, double special, const char* meaning, const ValidRange& range,
                      const std::string& what);

}  // namespace sph

#endif  // SPH_CORE_VALID_RANGE_HPP_
