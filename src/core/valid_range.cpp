#include "sph/core/valid_range.hpp"

#include <cmath>
#include <optional>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
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

namespace {

// "must be <special> (<meaning>) or >= lo and <= hi unit, got <text>".
std::string RefusalOr(const std::string& text, double special, const std::string& meaning, const ValidRange& range) {
  return "must be " + internal::Shortest(special) + " (" + meaning + ") or " +
         range.Refusal(text).substr(std::string("must be ").size());
}

// The typed number, or nothing when `text` is not a finite number (refused with the range).
std::optional<double> Typed(const std::string& text) {
  try {
    return ParseNumber(text, "", "");
  } catch (const Error&) {
    return std::nullopt;
  }
}

}  // namespace

std::string RefusalOf(const std::string& text, const ValidRange& range) {
  const std::optional<double> v = Typed(text);
  return v && range.Contains(*v) ? "" : range.Refusal(text);
}

std::string RefusalOf(const std::string& text, double special, const std::string& meaning, const ValidRange& range) {
  const std::optional<double> v = Typed(text);
  return v && (*v == special || range.Contains(*v)) ? "" : RefusalOr(text, special, meaning, range);
}

double CheckedValueOr(double value, double special, const char* meaning, const ValidRange& range,
                      const std::string& what) {
  if (value == special || range.Contains(value)) return value;
  throw Error(what + ": " + RefusalOr(internal::Shortest(value), special, meaning, range));
}

}  // namespace sph
