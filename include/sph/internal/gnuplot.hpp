// Text quoted for a gnuplot script, for the plots' scripts the library renders and the apps run.
// Not part of the public API.
#ifndef SPH_INTERNAL_GNUPLOT_HPP_
#define SPH_INTERNAL_GNUPLOT_HPP_

#include <string>

namespace sph::internal {

/// `s` as a gnuplot string in single quotes (a quote is doubled): for names and titles.
inline std::string GnuplotQuoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

/// `s` as a gnuplot string in double quotes, where "\n" is a line break.
inline std::string GnuplotDoubleQuoted(const std::string& s) {
  std::string q = "\"";
  for (const char c : s) {
    if (c == '\n') {
      q += "\\n";
    } else {
      if (c == '"' || c == '\\') q += '\\';
      q += c;
    }
  }
  return q + "\"";
}

}  // namespace sph::internal

#endif  // SPH_INTERNAL_GNUPLOT_HPP_
