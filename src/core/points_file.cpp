#include "sph/core/points_file.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <fstream>
#include <istream>
#include <map>
#include <ostream>
#include <set>
#include <sstream>
#include <tuple>

#include "sph/core/atomic_file.hpp"
#include "sph/core/error.hpp"
#include "sph/core/points_writer.hpp"

namespace sph {
namespace {

enum Column : int { kTheta = 0, kPhi, kR, kTime, kSetup, kNumColumns };
constexpr std::array<const char*, kNumColumns> kColumnNames{"theta_deg", "phi_deg", "r_mm", "t_s", "setup"};

std::string Trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> SplitWhitespace(const std::string& s) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    std::size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\t' && s[j] != '\r') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

bool IsKey(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

class LineError {
 public:
  LineError(const std::string& source, long line) : prefix_(source + ":" + std::to_string(line) + ": ") {}
  [[noreturn]] void operator()(const std::string& what) const { throw Error(prefix_ + what); }

 private:
  std::string prefix_;
};

// Parses a whole token as a finite double; the error names the column.
double ParseDouble(const std::string& token, const std::string& what, const LineError& fail) {
  double v = 0.0;
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec == std::errc::result_out_of_range) fail(what + ": '" + token + "' is out of the range of a double");
  if (ec != std::errc() || ptr != last) fail(what + ": '" + token + "' is not a number");
  if (!std::isfinite(v)) fail(what + ": '" + token + "' is not a finite number");
  return v;
}

int ParseInt(const std::string& token, const std::string& what, const LineError& fail) {
  int v = 0;
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec != std::errc() || ptr != last) fail(what + ": '" + token + "' is not an integer");
  return v;
}

}  // namespace

std::vector<int> PointsData::SetupIds() const {
  std::set<int> ids;
  for (const Sample& s : samples) ids.insert(s.setup);
  return {ids.begin(), ids.end()};
}

PointsData ReadPointsFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open for reading: " + std::strerror(errno));
  return ParsePoints(in, path);
}

PointsData ParsePoints(std::istream& in, const std::string& source) {
  PointsData data;
  data.source = source;
  std::set<std::string> seen_keys;
  std::vector<long> key_lines;
  std::array<int, kNumColumns> index{};  // file column index of each known column, -1 if absent
  index.fill(-1);
  bool columns_fixed = false;  // set at the first sample
  bool header_done = false;
  std::size_t n_columns = 0;
  std::string line;
  long line_no = 0;

  auto fix_columns = [&](const LineError& fail) {
    if (data.header.columns.empty()) data.header.columns = {"theta_deg", "phi_deg", "r_mm"};
    for (std::size_t i = 0; i < data.header.columns.size(); ++i) {
      const std::string& name = data.header.columns[i];
      const auto it = std::find(kColumnNames.begin(), kColumnNames.end(), name);
      if (it == kColumnNames.end()) {
        fail("unknown column name '" + name + "' (known: theta_deg phi_deg r_mm t_s setup)");
      }
      const auto k = static_cast<std::size_t>(it - kColumnNames.begin());
      if (index[k] >= 0) fail("column '" + name + "' is named twice");
      index[k] = static_cast<int>(i);
    }
    for (int k : {kTheta, kPhi, kR}) {
      if (index[static_cast<std::size_t>(k)] < 0) {
        fail(std::string("required column '") + kColumnNames[static_cast<std::size_t>(k)] + "' is missing");
      }
    }
    data.has_time = index[kTime] >= 0;
    data.has_setup = index[kSetup] >= 0;
    n_columns = data.header.columns.size();
    columns_fixed = true;
  };

  while (std::getline(in, line)) {
    ++line_no;
    const LineError fail(source, line_no);
    if (line.find('\0') != std::string::npos) fail("binary data (NUL byte): this is not a points file");
    const std::string text = Trim(line);
    if (text.empty()) continue;
    if (text[0] == '#') {
      if (header_done) continue;  // comments between samples
      const std::string body = Trim(text.substr(1));
      if (body.rfind("sph-points", 0) == 0) {
        const auto words = SplitWhitespace(body);
        if (words.size() != 2 || words[0] != "sph-points") fail("malformed format line '" + text + "'");
        if (words[1] != std::to_string(kPointsFormatVersion)) {
          fail("format 'sph-points " + words[1] + "' is not supported (this program reads sph-points " +
               std::to_string(kPointsFormatVersion) + ")");
        }
        continue;
      }
      const auto colon = body.find(':');
      if (colon == std::string::npos) continue;  // a plain comment
      const std::string key = Trim(body.substr(0, colon));
      if (!IsKey(key)) continue;  // prose that happens to contain a colon
      const std::string value = Trim(body.substr(colon + 1));
      if (!seen_keys.insert(key).second) fail("header key '" + key + "' is given twice");
      if (key == kRadiusKey || key == kProbeOffsetKey) {
        const double v = ParseDouble(value, key, fail);
        if (!(v > 0.0)) fail(key + " must be positive, got " + value);
        (key == kRadiusKey ? data.header.sphere_radius_mm : data.header.probe_offset_mm) = v;
      } else if (key == kColumnsKey) {
        data.header.columns = SplitWhitespace(value);
        if (data.header.columns.empty()) fail("the columns line names no columns");
      } else {
        data.header.metadata.emplace_back(key, value);
      }
      continue;
    }

    // A sample.
    if (!columns_fixed) fix_columns(fail);
    header_done = true;
    const auto tokens = SplitWhitespace(text);
    if (tokens.size() != n_columns) {
      std::string names;
      for (const auto& c : data.header.columns) names += (names.empty() ? "" : " ") + c;
      fail("expected " + std::to_string(n_columns) + " columns (" + names + "), found " +
           std::to_string(tokens.size()));
    }
    Sample s;
    auto col = [&](int k) { return tokens[static_cast<std::size_t>(index[static_cast<std::size_t>(k)])]; };
    auto name = [&](int k) { return std::string("column ") + kColumnNames[static_cast<std::size_t>(k)]; };
    s.theta_deg = ParseDouble(col(kTheta), name(kTheta), fail);
    s.phi_deg = ParseDouble(col(kPhi), name(kPhi), fail);
    s.r_mm = ParseDouble(col(kR), name(kR), fail);
    s.t_s = data.has_time ? ParseDouble(col(kTime), name(kTime), fail) : static_cast<double>(data.samples.size());
    s.setup = data.has_setup ? ParseInt(col(kSetup), name(kSetup), fail) : 0;
    data.samples.push_back(s);
  }
  if (in.bad()) throw Error(source + ": read error");
  if (data.samples.empty()) throw Error(source + ": no samples (the file has " + std::to_string(line_no) + " lines, none of them a sample)");
  return data;
}

std::vector<std::string> PlausibilityWarnings(const PointsData& data) {
  std::vector<std::string> out;
  if (data.samples.size() >= 10) {
    double t_lo = data.samples[0].theta_deg, t_hi = t_lo, p_lo = data.samples[0].phi_deg, p_hi = p_lo;
    for (const Sample& s : data.samples) {
      t_lo = std::min(t_lo, s.theta_deg);
      t_hi = std::max(t_hi, s.theta_deg);
      p_lo = std::min(p_lo, s.phi_deg);
      p_hi = std::max(p_hi, s.phi_deg);
    }
    constexpr double kTwoPi = 6.2832, kPi = 3.1416;
    // A measurement in degrees turns Theta through far more than 6.3 deg; one in radians stays within it.
    if (t_hi - t_lo > 1.0 && t_lo >= -kTwoPi && t_hi <= kTwoPi && p_lo >= -0.01 && p_hi <= kPi) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "theta_deg spans only %.4g..%.4g and phi_deg %.4g..%.4g: are the angles in radians? The "
                    "columns are in degrees",
                    t_lo, t_hi, p_lo, p_hi);
      out.emplace_back(data.source + ": " + buf);
    }
  }
  // Exact repeats of an earlier row: the rows sorted by their values (and then by row), each row
  // after the first of its values a repeat. (A sort of indices: 4 bytes a row, whatever the file.)
  // Without a t_s column the time is the row index, which no repeat shares.
  auto key = [&](std::size_t i) {
    const Sample& s = data.samples[i];
    return std::make_tuple(s.theta_deg, s.phi_deg, s.r_mm, data.has_time ? s.t_s : 0.0, s.setup);
  };
  std::vector<std::uint32_t> order(data.samples.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const auto ka = key(a), kb = key(b);
    return ka < kb || (ka == kb && a < b);
  });
  std::size_t repeats = 0, first = data.samples.size();
  for (std::size_t j = 1; j < order.size(); ++j) {
    if (key(order[j]) != key(order[j - 1])) continue;
    ++repeats;
    first = std::min<std::size_t>(first, order[j]);
  }
  if (repeats > 0) {
    out.push_back(data.source + ": " + std::to_string(repeats) + " sample(s) repeat an earlier one exactly (the first: " +
                  "sample " + std::to_string(first + 1) + "); a repeated reading counts twice in a fit");
  }
  return out;
}

void WritePoints(std::ostream& out, const PointsData& data) {
  out << "# sph-points " << kPointsFormatVersion << "\n";
  char buf[160];
  if (data.header.sphere_radius_mm) {
    std::snprintf(buf, sizeof buf, "%.17g", *data.header.sphere_radius_mm);
    out << "# " << kRadiusKey << ": " << buf << "\n";
  }
  if (data.header.probe_offset_mm) {
    std::snprintf(buf, sizeof buf, "%.17g", *data.header.probe_offset_mm);
    out << "# " << kProbeOffsetKey << ": " << buf << "\n";
  }
  for (const auto& [key, value] : data.header.metadata) out << "# " << key << ": " << value << "\n";
  out << "# " << kColumnsKey << ": theta_deg phi_deg r_mm" << (data.has_time ? " t_s" : "")
      << (data.has_setup ? " setup" : "") << "\n";
  // 10 decimals: 1e-10 deg (2 pm of arc at 20 mm) and 0.1 pm in r, far below any instrument.
  for (const Sample& s : data.samples) out << PointsWriter::FormatRow(s, data.has_time, data.has_setup);
}

void WritePointsFile(const std::string& path, const PointsData& data) {
  WriteFileAtomically(path, [&](std::ostream& out) { WritePoints(out, data); });
}

}  // namespace sph
