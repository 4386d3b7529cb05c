// printf into a std::string, and text quoted for messages. Not part of the public API.
#ifndef SPH_INTERNAL_FORMAT_HPP_
#define SPH_INTERNAL_FORMAT_HPP_

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace sph::internal {

/// snprintf into a std::string of whatever length the result has (never cut).
template <typename... Args>
std::string Format(const char* format, Args... args) {
  char small[256];
  const int n = std::snprintf(small, sizeof small, format, args...);
  if (n < 0) return "";
  if (static_cast<std::size_t>(n) < sizeof small) return std::string(small, static_cast<std::size_t>(n));
  std::string out(static_cast<std::size_t>(n) + 1, '\0');
  std::snprintf(out.data(), out.size(), format, args...);
  out.resize(static_cast<std::size_t>(n));
  return out;
}

/// `text` in single quotes for a message, cut to its first 40 characters when longer
/// ("'1111111111111111111111111111111111111111...' (1048576 characters)"), and with bytes that are
/// not printable ASCII shown as \xHH, so that a message stays one readable line whatever the input.
inline std::string Quoted(std::string_view text) {
  constexpr std::size_t kShown = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < text.size() && i < kShown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
    }
  }
  out += text.size() > kShown ? "...'" : "'";
  if (text.size() > kShown) out += " (" + std::to_string(text.size()) + " characters)";
  return out;
}

/// The shortest text (15 to 17 significant digits) that reads back as `v`: 12.7, not
/// 12.699999999999999.
inline std::string Shortest(double v) {
  char buf[40];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

}  // namespace sph::internal

#endif  // SPH_INTERNAL_FORMAT_HPP_
