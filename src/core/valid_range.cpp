#include "sph/core/valid_range.hpp"

#include <cmath>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph {

using internal::Format;
using internal::Quoted;

bool ValidRange::Contains(double v) const {
  return std::isfinite(v) && (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
}

std::string ValidRange::Text() const {
  return Format("%g %s x %s %g", lo, lo_open ? "<" : "<=", hi_open ? "<" : "<=", hi) + (*unit ? " " : "") + unit;
}

std::string ValidRange::Refusal(const std::string& text) const {
  return Format("must be %s %g and %s %g", lo_open ? ">" : ">=", lo, hi_open ? "<" : "<=", hi) + (*unit ? " " : "") +
         unit + ", got " + (text.size() > 40 ? Quoted(text) : text);
}

double CheckedValue(double value, const ValidRange& range, const std::string& what, const std::string& text) {
  if (!range.Contains(value)) throw Error(what + ": " + range.Refusal(text));
  return value;
}

double CheckedValue(double value, const ValidRange& range, const std::string& what) {
  return CheckedValue(value, range, what, internal::Shortest(value));
}

double CheckedValueOr(double value, double special, const char* meaning, const ValidRange& range,
                      const std::string& what) {
  if (value == special || range.Contains(value)) return value;
  const std::string refusal = range.Refusal(internal::Shortest(value));
  throw Error(what + ": must be " + internal::Shortest(special) + " (" + meaning + ") or " +
              refusal.substr(std::string("must be ").size()));
}

}  // namespace sph
