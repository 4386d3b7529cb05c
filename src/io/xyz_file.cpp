#include "sph/io/xyz_file.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <istream>
#include <ostream>

#include "sph/core/error.hpp"
#include "sph/io/output_files.hpp"
#include "sph/core/text_input.hpp"

namespace sph {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// The fields of a line separated by blanks or by commas (with blanks around them). Two commas
// with nothing between them are an empty field: "1,2,,3" is refused, not read as "1 2 3".
std::vector<std::string> SplitFields(const std::string& s, const std::string& where) {
  std::vector<std::string> out;
  std::size_t i = 0;
  bool after_comma = false;
  while (i < s.size()) {
    while (i < s.size() && IsBlank(s[i])) ++i;
    if (i < s.size() && s[i] == ',') {
      if (after_comma || out.empty()) throw Error(where + "an empty field between commas");
      after_comma = true;
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < s.size() && !IsBlank(s[j]) && s[j] != ',') ++j;
    if (j > i) {
      out.push_back(s.substr(i, j - i));
      after_comma = false;
    }
    i = j;
  }
  if (after_comma) throw Error(where + "the line ends with a comma");
  return out;
}

// A whole token that is a non-negative integer (the NIST point-count line).
bool ParseCount(const std::string& token, long* count) {
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), *count);
  return ec == std::errc() && ptr == token.data() + token.size() && *count >= 0;
}

}  // namespace

std::vector<Eigen::Vector3d> ReadXyzFile(const std::string& path) {
  std::ifstream in = OpenInputFile(path);
  return ParseXyz(in, path);
}

std::vector<Eigen::Vector3d> ParseXyz(std::istream& in, const std::string& source) {
  std::vector<Eigen::Vector3d> points;
  long announced = -1;  // the NIST count line, when there is one
  long count_line = 0;
  bool first_data_line = true;
  std::string line;
  TextLines lines(in, source, "a text file of points");
  while (lines.Next(line)) {
    const long line_no = lines.line_no();
    const std::string where = lines.Where();
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto fields = SplitFields(line, where);
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
    points.emplace_back(ParseNumber(fields[0], "x", where), ParseNumber(fields[1], "y", where),
                        ParseNumber(fields[2], "z", where));
  }
  if (announced >= 0 && static_cast<long>(points.size()) != announced) {
    throw Error(lines.Where(count_line) + "the count line announces " + std::to_string(announced) +
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
