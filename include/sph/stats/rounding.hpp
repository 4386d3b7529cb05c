// A result as a certificate states it (JCGM 100:2008, the GUM, 7.2.6): the uncertainty to at most
// two significant digits, the value rounded to the same decimal place. The reports' text and HTML
// and the Digital Calibration Certificate print through it; the JSON reports and the calibration
// file keep every digit.
//
//   RoundResult(10.05762, 0.027)   -> "10.058", "0.027"    (GUM 7.2.6: y = 10.058 ohm, u_c = 27 mohm)
//   RoundResult(100.02147, 0.00079) -> "100.02147", "0.00079" (GUM 7.2.4)
//   RoundResult(3.21, 9.96)        -> "3", "10"            (a 9 that carries: still two digits, "10")
//
// The uncertainty is rounded to the nearest, not up: with two significant digits that lowers it by
// less than 5 % (10.49 -> 10), the limit below which EA-4/02 lets a laboratory round down. The
// decimal place follows the rounded uncertainty's two digits, so 0.0996 gives "0.10" and the value
// two decimals. A value that rounds to zero prints "0.000", never "-0.000".
#ifndef SPH_STATS_ROUNDING_HPP_
#define SPH_STATS_ROUNDING_HPP_

#include <string>

namespace sph::gum {

/// A value and its uncertainty, rounded for a statement.
struct RoundedResult {
  std::string value_text;        ///< "10.058"; "-" for a value that is not finite
  std::string uncertainty_text;  ///< "0.027"; "0" for an exact value, "-" for an uncertainty not known
  double value = 0.0;            ///< value_text read back
  double uncertainty = 0.0;      ///< uncertainty_text read back (0 when exact or not known)
  /// Digits after the decimal point of both texts; negative when rounded to tens (-1), hundreds
  /// (-2), ... An uncertainty not known rounds the value to 6 significant digits.
  int decimals = 0;
  /// The uncertainty is 0: the value is printed in full (the shortest text that reads back as it).
  bool exact = false;
  /// Half a unit of the last decimal: how far value_text may lie from the value it states (0 when
  /// exact).
  double HalfUnit() const;
};

/// `value` and its `uncertainty` (a standard or an expanded uncertainty, >= 0; its sign is
/// ignored) as GUM 7.2.6 states them: the uncertainty to `significant_digits` (1 or more; 2 is the
/// GUM's "at most two"), the value to the same decimal place.
RoundedResult RoundResult(double value, double uncertainty, int significant_digits = 2);

/// `x` alone to `significant_digits` significant digits, in fixed notation ("0.0042", "1200",
/// "-3.5"); "0" for zero, "-" for a value that is not finite. For a budget's contributions and
/// other numbers that qualify a result rather than state it.
std::string SignificantText(double x, int significant_digits = 2);

}  // namespace sph::gum

#endif  // SPH_STATS_ROUNDING_HPP_
