#include "sph/stats/rounding.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "sph/internal/format.hpp"

namespace sph::gum {
namespace {

using internal::Format;

// The decimal place (digits after the point; negative for tens, hundreds, ...) at which |x|, x
// finite and not 0, has `digits` significant digits once rounded: printf's %e rounds in decimal and
// carries (9.96 to 2 digits is "1.0e+01"), so the exponent is the rounded number's.
int DecimalsFor(double x, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*e", digits - 1, std::fabs(x));
  const char* e = std::strchr(text, 'e');
  return digits - 1 - (e != nullptr ? std::atoi(e + 1) : 0);
}

// x rounded at `decimals` in fixed notation; a result whose digits are all 0 has no sign.
std::string FixedAt(double x, int decimals) {
  std::string text;
  if (decimals >= 0) {
    text = Format("%.*f", decimals, x);
  } else {
    const double unit = std::pow(10.0, -decimals);
    text = Format("%.0f", std::round(x / unit) * unit);
  }
  if (!text.empty() && text[0] == '-' && text.find_first_of("123456789") == std::string::npos) text.erase(0, 1);
  return text;
}

}  // namespace

double RoundedResult::HalfUnit() const { return exact ? 0.0 : 0.5 * std::pow(10.0, -decimals); }

RoundedResult RoundResult(double value, double uncertainty, int significant_digits) {
  const int digits = std::max(1, significant_digits);
  const double u = std::fabs(uncertainty);
  RoundedResult r;
  if (!std::isfinite(value)) {
    r.value_text = "-";
    r.value = value;
    r.uncertainty_text = std::isfinite(u) ? SignificantText(u, digits) : "-";
    r.uncertainty = std::isfinite(u) ? std::strtod(r.uncertainty_text.c_str(), nullptr) : 0.0;
    return r;
  }
  if (u == 0.0) {
    r.exact = true;
    r.value_text = internal::Shortest(value == 0.0 ? 0.0 : value);
    r.value = value;
    r.uncertainty_text = "0";
    return r;
  }
  if (!std::isfinite(u)) {
    r.decimals = value == 0.0 ? 0 : DecimalsFor(value, 6);
    r.value_text = FixedAt(value, r.decimals);
    r.value = std::strtod(r.value_text.c_str(), nullptr);
    r.uncertainty_text = "-";
    return r;
  }
  r.decimals = DecimalsFor(u, digits);
  r.uncertainty_text = FixedAt(u, r.decimals);
  r.uncertainty = std::strtod(r.uncertainty_text.c_str(), nullptr);
  r.value_text = FixedAt(value, r.decimals);
  r.value = std::strtod(r.value_text.c_str(), nullptr);
  return r;
}

std::string SignificantText(double x, int significant_digits) {
  if (!std::isfinite(x)) return "-";
  if (x == 0.0) return "0";
  return FixedAt(x, DecimalsFor(x, std::max(1, significant_digits)));
}

}  // namespace sph::gum
