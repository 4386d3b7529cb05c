#include "sph/core/xyz_file.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <istream>
#include <ostream>

#include "sph/core/atomic_file.hpp"
#include "sph/core/error.hpp"

namespace sph {
namespace {

bool IsSeparator(char c) { return c == ' ' || c == '\t' || c == '\r' || c == ','; }

std::vector<std::string> SplitFields(const std::string& s) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && IsSeparator(s[i])) ++i;
    std::size_t j = i;
    while (j < s.size() && !IsSeparator(s[j])) ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string Where(const std::string& source, long line) { return source + ":" + std::to_string(line) + ": "; }

double ParseCoordinate(const std::string& token, const char* axis, const std::string& where) {
  double v = 0.0;
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec == std::errc::result_out_of_range)
    throw Error(where + axis + ": '" + token + "' is out of the range of a double");
  if (ec != std::errc() || ptr != last) throw Error(where + axis + ": '" + token + "' is not a number");
  if (!std::isfinite(v)) throw Error(where + axis + ": '" + token + "' is not a finite number");
  return v;
}

// A whole token that is a non-negative integer (the NIST point-count line).
bool ParseCount(const std::string& token, long* count) {
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), *count);
  return ec == std::errc() && ptr == token.data() + token.size() && *count >= 0;
}

}  // namespace

std::vector<Eigen::Vector3d> ReadXyzFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open for reading: " + std::strerror(errno));
  return ParseXyz(in, path);
}

std::vector<Eigen::Vector3d> ParseXyz(std::istream& in, const std::string& source) {
  std::vector<Eigen::Vector3d> points;
  long announced = -1;  // the NIST count line, when there is one
  long count_line = 0;
  bool first_data_line = true;
  std::string line;
  long line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = Where(source, line_no);
    if (line.find('\0') != std::string::npos)
      throw Error(where + "binary data (NUL byte): this is not a text file of points");
    const auto fields = SplitFields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    if (first_data_line) {
      first_data_line = false;
      if (fields.size() == 1 && ParseCount(fields[0], &announced)) {
        count_line = line_no;
        continue;
      }
    }
    if (fields.size() != 3) {
      throw Error(where + "expected 3 numbers (x y z), found " + std::to_string(fields.size()) + " fields");
    }
    points.emplace_back(ParseCoordinate(fields[0], "x", where), ParseCoordinate(fields[1], "y", where),
                        ParseCoordinate(fields[2], "z", where));
  }
  if (in.bad()) throw Error(source + ": read error");
  if (announced >= 0 && static_cast<long>(points.size()) != announced) {
    throw Error(Where(source, count_line) + "the count line announces " + std::to_string(announced) +
                " points, but the file holds " + std::to_string(points.size()));
  }
  if (points.empty()) throw Error(source + ": no points (expected lines 'x y z')");
  return points;
}

void WriteXyz(std::ostream& out, const std::vector<Eigen::Vector3d>& points, const std::vector<std::string>& comments) {
  for (const auto& c : comments) out << "# " << c << "\n";
  char buf[1000];  // three of the longest %.10f (sign, 309 digits, point, 10 decimals) fit
  for (const auto& p : points) {
    std::snprintf(buf, sizeof buf, "%.10f %.10f %.10f", p.x(), p.y(), p.z());
    out << buf << "\n";
  }
}

void WriteXyzFile(const std::string& path, const std::vector<Eigen::Vector3d>& points,
                  const std::vector<std::string>& comments) {
  WriteFileAtomically(path, [&](std::ostream& out) { WriteXyz(out, points, comments); });
}

}  // namespace sph
