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

}  // namespace sph
