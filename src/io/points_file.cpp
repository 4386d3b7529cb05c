#include "sph/io/points_file.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <istream>
#include <limits>
#include <map>
#include <ostream>
#include <set>
#include <sstream>
#include <tuple>

#include "sph/core/error.hpp"
#include "sph/io/output_files.hpp"
#include "sph/io/points_writer.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Quoted;

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

// Throws "<source>:<line>: <what>".
class LineError {
 public:
  explicit LineError(std::string where) : where_(std::move(where)) {}
  [[noreturn]] void operator()(const std::string& what) const { throw Error(where_ + what); }
  const std::string& where() const { return where_; }

 private:
  std::string where_;
};

// A header field's text is copied into reports and JSON files: it must be UTF-8 (a report cannot
// say what other bytes mean).
void CheckHeaderText(const HeaderField& f, const LineError& fail) {
  if (f.value.find('\r') != std::string::npos) {
    fail(f.key + ": " + Quoted(f.value) +
         " holds a carriage return: a header field is one line (a line ends in LF or CR LF, never CR alone)");
  }
  for (const std::string* text : {&f.key, &f.value}) {
    const std::string reason = NotUtf8Reason(*text);
    if (reason.empty()) continue;
    fail((text == &f.key ? "header key " : f.key + ": ") + Quoted(*text) + " " + reason +
         ": save the file as UTF-8, for the reports copy the header's text");
  }
}

}  // namespace

bool IsHeaderKey(std::string_view key) {
  const auto is_name_char = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  };
  const auto at = key.find('@');
  const std::string_view name = key.substr(0, at);
  if (name.empty() || !std::all_of(name.begin(), name.end(), is_name_char)) return false;
  if (at == std::string_view::npos) return true;
  return key.substr(at + 1).find_first_of(" \t\r") == std::string_view::npos;
}

std::optional<HeaderField> HeaderFieldOf(std::string_view body) {
  const auto colon = body.find(':');
  if (colon == std::string_view::npos) return std::nullopt;
  HeaderField f{Trim(std::string(body.substr(0, colon))), Trim(std::string(body.substr(colon + 1)))};
  if (!IsHeaderKey(f.key)) return std::nullopt;
  return f;
}

std::string MountRotationKey(int setup) { return std::string(kMountRotationKey) + "@" + std::to_string(setup); }

std::string SphereRadiusKey(int setup) { return std::string(kRadiusKey) + "@" + std::to_string(setup); }

std::string SetupFieldLines(const PointsHeader& header, const std::map<std::string, std::string>& written) {
  std::string lines;
  for (const auto& [setup, rotation] : header.mount_rotations) {
    const std::string key = MountRotationKey(setup);
    if (written.count(key) == 0) lines += "# " + key + ": " + MountRotationValue(rotation) + "\n";
  }
  for (const auto& [setup, radius_mm] : header.sphere_radii_mm) {
    const std::string key = SphereRadiusKey(setup);
    if (written.count(key) == 0) lines += "# " + key + ": " + internal::Shortest(radius_mm) + "\n";
  }
  return lines;
}

std::string PointsHeader::FormKey(int setup) const {
  const auto rotation = mount_rotations.find(setup);
  if (rotation != mount_rotations.end() && !rotation->second.known()) return "unknown@" + std::to_string(setup);
  const auto other = sphere_radii_mm.find(setup);
  return other == sphere_radii_mm.end() ? "" : std::string(kRadiusKey) + " " + internal::Shortest(other->second);
}

std::string MountRotationValue(const MountRotation& rotation) {
  if (!rotation.known()) return "unknown";
  const Eigen::Vector3d& v = *rotation.rotation_deg;
  return internal::Shortest(v.x()) + " " + internal::Shortest(v.y()) + " " + internal::Shortest(v.z());
}

bool SameOrientation(const MountRotation& a, const MountRotation& b) {
  if (!a.known() || !b.known()) return a.known() == b.known();
  const Eigen::Matrix3d between =
      MountRotationMatrix(*a.rotation_deg).transpose() * MountRotationMatrix(*b.rotation_deg);
  return Eigen::AngleAxisd(between).angle() * kDegPerRad <= kMountRotationToleranceDeg;
}

MountRotation ParseMountRotation(const std::string& value, const std::string& key, const std::string& where) {
  const std::vector<std::string> words = SplitWhitespace(value);
  if (words.size() == 1 && words[0] == "unknown") return MountRotation::Unknown();
  if (words.size() != 3) {
    throw Error(where + key +
                ": expected 'rx ry rz' (a rotation vector in deg, axis times angle) or 'unknown', found " +
                std::to_string(words.size()) + (words.size() == 1 ? " value" : " values"));
  }
  Eigen::Vector3d v;
  constexpr std::array<const char*, 3> kNames{"rx", "ry", "rz"};
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string what = key + " " + kNames[i];
    v(static_cast<Eigen::Index>(i)) = ParseNumber(words[i], what, where);
    if (std::abs(v(static_cast<Eigen::Index>(i))) > kMaxMountRotationDeg) {
      throw Error(where + what + ": must be within [-" + internal::Format("%g", kMaxMountRotationDeg) + ", " +
                  internal::Format("%g", kMaxMountRotationDeg) + "] deg, got " + Quoted(words[i]));
    }
  }
  return MountRotation::Known(v);
}

std::vector<int> PointsData::SetupIds() const {
  std::set<int> ids;
  for (const Sample& s : samples) ids.insert(s.setup);
  return {ids.begin(), ids.end()};
}

std::string PointsData::WhereIs(std::size_t i) const {
  if (i < sample_lines.size()) return source + ":" + std::to_string(sample_lines[i]);
  return source + ": sample " + std::to_string(i + 1);
}

PointsData ReadPointsFile(const std::string& path) {
  std::ifstream in = OpenInputFile(path);
  return ParsePoints(in, path);
}

namespace {

// Reads a points file line by line: the header's format line and keys until the first sample,
// then samples (comments between them skipped). Each method throws "<source>:<line>: <what>".
class PointsParser {
 public:
  explicit PointsParser(const std::string& source) {
    data_.source = source;
    index_.fill(-1);
  }

  // One line (trimmed; empty lines skipped), number `line_no`.
  void Line(const std::string& text, long line_no, const LineError& fail) {
    line_no_ = line_no;
    if (text.empty()) return;
    if (text[0] != '#') return SampleLine(text, fail);
    // Between samples, comments are skipped, but for the fields of a setup that a later run
    // appended to the file before the setup's first row (its mount rotation, its sphere's
    // radius), and header fields this reader knows, which would apply to no row here.
    if (!header_done_) return HeaderLine(Trim(text.substr(1)), text, fail);
    const std::optional<HeaderField> f = HeaderFieldOf(text.substr(1));
    if (!f) return;
    const auto at = f->key.find('@');
    if (at != std::string::npos) {
      if (!SetupLine(f->key, at, f->value, fail)) RefuseSetupSuffix(f->key, at, fail);
    } else if (IsKnownKey(f->key)) {
      const std::string first = std::to_string(data_.sample_lines.front());
      if (f->key == kColumnsKey) {
        fail("a columns line after the first sample (line " + first +
             "): the columns are named once, before the samples, and the rows above were read without it");
      }
      fail("header field " + Quoted(f->key) + " after the first sample (line " + first +
           "): header fields stand before the samples");
    }
  }

  // The data, once every line was read.
  PointsData Finish() {
    if (data_.samples.empty()) {
      throw Error(data_.source + ": no samples (the file has " + std::to_string(line_no_) +
                  " lines, none of them a sample)");
    }
    CheckSetupFields();
    return std::move(data_);
  }

 private:
  // A header line: `body` after its '#', `text` the whole line.
  void HeaderLine(const std::string& body, const std::string& text, const LineError& fail) {
    if (body.rfind("sph-points", 0) == 0) return FormatLine(body, text, fail);
    const std::optional<HeaderField> f = HeaderFieldOf(body);
    if (!f) return;  // a plain comment, or prose that happens to contain a colon
    const std::string& key = f->key;
    const std::string& value = f->value;
    CheckHeaderText(*f, fail);
    if (!seen_keys_.insert(key).second) fail("header key " + Quoted(key) + " is given twice");
    const auto at = key.find('@');
    if (SetupLine(key, at, value, fail)) return;
    if (at != std::string::npos) RefuseSetupSuffix(key, at, fail);
    if (key == kRadiusKey || key == kProbeOffsetKey) return LengthLine(key, value, fail);
    if (key == kColumnsKey) {
      data_.header.columns = SplitWhitespace(value);
      if (data_.header.columns.empty()) fail("the columns line names no columns");
      return FixColumns(fail);
    }
    if (key == kFixKey) ParseFixedParameters(value, fail.where() + key);
    if (key == kPriorKey) ParseParameterPriors(value, fail.where() + key);
    for (const ConditionField& c : kConditionFields) {
      if (key != c.key) continue;
      const double v = ParseNumber(value, key, fail.where());
      if (!(v >= c.min && v <= c.max)) {
        fail(key + " must be within [" + internal::Format("%g", c.min) + ", " + internal::Format("%g", c.max) + "] " +
             c.unit + ", got " + Quoted(value));
      }
    }
    data_.header.metadata.emplace_back(key, value);
  }

  // A key with a setup suffix (its '@' at `at`) whose name is a field of the whole file ("fix@0",
  // "sphere_form_rms_um@0"): refused, for it would otherwise be kept as metadata and state nothing.
  static void RefuseSetupSuffix(const std::string& key, std::size_t at, const LineError& fail) {
    const std::string name = key.substr(0, at);
    if (!IsKnownKey(name) && name != kFixKey && name != kPriorKey) return;
    fail("header key " + Quoted(key) + ": " + name + " belongs to the whole file and takes no setup suffix (@" +
         key.substr(at + 1) + "); only " + kMountRotationKey + " and " + kRadiusKey + " are given per setup");
  }

  // A header key this reader takes a value from (not metadata).
  static bool IsKnownKey(const std::string& key) {
    if (key == kRadiusKey || key == kProbeOffsetKey || key == kColumnsKey) return true;
    for (const ConditionField& c : kConditionFields) {
      if (key == c.key) return true;
    }
    return false;
  }

  static void FormatLine(const std::string& body, const std::string& text, const LineError& fail) {
    const auto words = SplitWhitespace(body);
    if (words.size() != 2 || words[0] != "sph-points") fail("malformed format line " + Quoted(text));
    if (words[1] != std::to_string(kPointsFormatVersion)) {
      fail("format " + Quoted("sph-points " + words[1]) + " is not supported (this program reads sph-points " +
           std::to_string(kPointsFormatVersion) + ")");
    }
  }

  // A field of one setup (mount_rotation_deg@<setup>, sphere_radius_mm@<setup>; the key's '@' at
  // `at`, or npos): false for a key that is none.
  bool SetupLine(const std::string& key, std::size_t at, const std::string& value, const LineError& fail) {
    const std::string name = key.substr(0, at);
    const bool rotation = name == kMountRotationKey;
    if (!rotation && !(name == kRadiusKey && at != std::string::npos)) return false;
    const std::string form = name + "@<setup>: " + (rotation ? "rx ry rz" : "R");
    if (at == std::string::npos) fail(name + " belongs to one setup: write '" + form + "'");
    if (at + 1 == key.size()) fail(key + " names no setup: write '" + form + "'");
    const int setup = ParseInteger(key.substr(at + 1), key + ": setup id", fail.where());
    const std::string what = rotation ? "the mount rotation" : "the sphere radius";
    const auto [it, inserted] = setup_lines_.emplace(std::make_pair(name, setup), line_no_);
    if (!inserted) {
      fail(what + " of setup " + std::to_string(setup) + " is given twice (first at line " +
           std::to_string(it->second) + ")");
    }
    const auto first_row = first_rows_.find(setup);
    if (first_row != first_rows_.end()) {
      fail(key + ": setup " + std::to_string(setup) + " has rows before this line (the first at line " +
           std::to_string(first_row->second) + "): " + what +
           " of a setup applies to all of its rows and stands before the first of them");
    }
    if (rotation) {
      data_.header.mount_rotations[setup] = ParseMountRotation(value, key, fail.where());
    } else {
      data_.header.sphere_radii_mm[setup] = PositiveMm(key, value, kMaxSphereRadiusMm, fail);
    }
    return true;
  }

  // sphere_radius_mm or probe_offset_mm.
  void LengthLine(const std::string& key, const std::string& value, const LineError& fail) {
    const double max = key == kRadiusKey ? kMaxSphereRadiusMm : kMaxProbeOffsetMm;
    (key == kRadiusKey ? data_.header.sphere_radius_mm : data_.header.probe_offset_mm) =
        PositiveMm(key, value, max, fail);
  }

  // A length field's value: a positive number of mm, at most max_mm.
  static double PositiveMm(const std::string& key, const std::string& value, double max_mm, const LineError& fail) {
    const double v = ParseNumber(value, key, fail.where());
    if (!(v > 0.0)) fail(key + " must be positive, got " + Quoted(value));
    if (v > max_mm) fail(key + " must be at most " + internal::Format("%g", max_mm) + " mm, got " + Quoted(value));
    return v;
  }

  // Checks the columns (those of the columns line, at its own line, or the default ones).
  void FixColumns(const LineError& fail) {
    if (data_.header.columns.empty()) data_.header.columns = {"theta_deg", "phi_deg", "r_mm"};
    for (std::size_t i = 0; i < data_.header.columns.size(); ++i) {
      const std::string& name = data_.header.columns[i];
      const auto it = std::find(kColumnNames.begin(), kColumnNames.end(), name);
      if (it == kColumnNames.end()) {
        fail("unknown column name " + Quoted(name) + " (known: theta_deg phi_deg r_mm t_s setup)");
      }
      const auto k = static_cast<std::size_t>(it - kColumnNames.begin());
      if (index_[k] >= 0) fail("column '" + name + "' is named twice");
      index_[k] = static_cast<int>(i);
    }
    for (int k : {kTheta, kPhi, kR}) {
      if (index_[static_cast<std::size_t>(k)] < 0) {
        fail(std::string("required column '") + kColumnNames[static_cast<std::size_t>(k)] + "' is missing");
      }
    }
    data_.has_time = index_[kTime] >= 0;
    data_.has_setup = index_[kSetup] >= 0;
    columns_fixed_ = true;
  }

  void SampleLine(const std::string& text, const LineError& fail) {
    if (!columns_fixed_) FixColumns(fail);
    header_done_ = true;
    const auto tokens = SplitWhitespace(text);
    const std::size_t n_columns = data_.header.columns.size();
    // Values separated by commas (a CSV export) or written with a decimal comma.
    const std::string commas =
        text.find(',') == std::string::npos
            ? ""
            : " (the line holds commas: a points file separates its values by spaces or tabs, and a decimal point "
              "is '.')";
    if (tokens.size() != n_columns) {
      std::string names;
      for (const auto& c : data_.header.columns) names += (names.empty() ? "" : " ") + c;
      fail("expected " + std::to_string(n_columns) + " columns (" + names + "), found " +
           std::to_string(tokens.size()) + commas);
    }
    Sample s;
    auto col = [&](int k) { return tokens[static_cast<std::size_t>(index_[static_cast<std::size_t>(k)])]; };
    try {
      s.theta_deg = ParseNumber(col(kTheta), ColumnName(kTheta), fail.where());
      s.phi_deg = ParseNumber(col(kPhi), ColumnName(kPhi), fail.where());
      s.r_mm = ParseNumber(col(kR), ColumnName(kR), fail.where());
      if (data_.has_time) s.t_s = ParseNumber(col(kTime), ColumnName(kTime), fail.where());
      s.setup = data_.has_setup ? ParseInteger(col(kSetup), ColumnName(kSetup), fail.where()) : 0;
    } catch (const Error& e) {
      throw Error(e.what() + commas);
    }
    if (!data_.has_time) s.t_s = static_cast<double>(data_.samples.size());
    const int beyond = ColumnBeyondLimit(s, data_.has_time);
    if (beyond >= 0) fail(BeyondLimit(beyond, col(beyond)));
    data_.samples.push_back(s);
    data_.sample_lines.push_back(line_no_);
    first_rows_.emplace(s.setup, line_no_);
  }

 public:
  // Samples of a host's arrays after the header (PointsFromColumns()), each checked as a row is and
  // named "<source>: sample <i>: " (from 1).
  void ColumnSamples(const PointsColumns& c) {
    if (!columns_fixed_) FixColumns(LineError(data_.source + ": "));
    header_done_ = true;
    data_.samples.resize(c.n);
    for (std::size_t i = 0; i < c.n; ++i) {
      const std::size_t at = i * c.stride;
      Sample& s = data_.samples[i];
      s.theta_deg = c.theta_deg[at];
      s.phi_deg = c.phi_deg[at];
      s.r_mm = c.r_mm[at];
      s.t_s = c.t_s != nullptr ? c.t_s[at] : static_cast<double>(i);
      const double setup = c.setup != nullptr ? c.setup[at] : 0.0;
      const double values[kNumColumns] = {s.theta_deg, s.phi_deg, s.r_mm, s.t_s, setup};
      for (int k = 0; k < kNumColumns; ++k) {
        const double v = values[k];
        if (std::isfinite(v)) continue;
        SampleError(i, ColumnName(k) + ": " + Quoted(internal::Format("%g", v)) + " is not a finite number");
      }
      if (setup != std::trunc(setup)) {
        SampleError(i, ColumnName(kSetup) + ": " + Quoted(internal::Shortest(setup)) + " is not an integer");
      }
      if (setup < std::numeric_limits<int>::min() || setup > std::numeric_limits<int>::max()) {
        SampleError(i, ColumnName(kSetup) + ": " + Quoted(internal::Shortest(setup)) +
                           " is out of the range of an integer (" + std::to_string(std::numeric_limits<int>::min()) +
                           " to " + std::to_string(std::numeric_limits<int>::max()) + ")");
      }
      s.setup = static_cast<int>(setup);
      const int beyond = ColumnBeyondLimit(s, c.t_s != nullptr);
      if (beyond >= 0) SampleError(i, BeyondLimit(beyond, internal::Shortest(values[beyond])));
    }
  }

 private:
  [[noreturn]] void SampleError(std::size_t i, const std::string& what) const {
    throw Error(data_.source + ": sample " + std::to_string(i + 1) + ": " + what);
  }

  static std::string ColumnName(int k) { return std::string("column ") + kColumnNames[static_cast<std::size_t>(k)]; }

  // The first column of `s` whose value is beyond what files accept (kMaxAngleDeg, kMaxReadingMm,
  // kMaxTimeS), or -1.
  static int ColumnBeyondLimit(const Sample& s, bool has_time) {
    if (std::abs(s.theta_deg) > kMaxAngleDeg) return kTheta;
    if (std::abs(s.phi_deg) > kMaxAngleDeg) return kPhi;
    if (std::abs(s.r_mm) > kMaxReadingMm) return kR;
    if (has_time && std::abs(s.t_s) > kMaxTimeS) return kTime;
    return -1;
  }

  // The refusal of column k's value (`text` as given) beyond its limit.
  static std::string BeyondLimit(int k, const std::string& text) {
    const std::string start = ColumnName(k) + ": " + Quoted(text) + " is beyond ";
    switch (k) {
      case kTheta:
      case kPhi:
        return start + internal::Format("%g", kMaxAngleDeg) + " deg from 0: not an encoder's angle";
      case kR:
        return start + internal::Format("%g", kMaxReadingMm) + " mm from 0: not a probe reading in mm";
      default:
        return start + internal::Format("%g", kMaxTimeS) + " s from 0: not a time of a measurement";
    }
  }

  // A field of a setup that has no samples: a typo in the setup id, or a setup whose rows went
  // missing.
  void CheckSetupFields() const {
    if (setup_lines_.empty()) return;
    const std::vector<int> ids = data_.SetupIds();
    for (const auto& [field, header_line] : setup_lines_) {
      const auto& [name, setup] = field;
      if (std::binary_search(ids.begin(), ids.end(), setup)) continue;
      std::string have;
      for (int id : ids) have += (have.empty() ? "" : " ") + std::to_string(id);
      throw Error(data_.source + ":" + std::to_string(header_line) + ": " + name + "@" + std::to_string(setup) +
                  ": setup " + std::to_string(setup) + " has no samples (" +
                  (data_.has_setup ? "the file's setups: " + have
                                   : std::string("the file has no setup column: all its samples are setup 0")) +
                  ")");
    }
  }

  PointsData data_;
  std::set<std::string> seen_keys_;
  std::map<std::pair<std::string, int>, long> setup_lines_;  // the header line of each (field, setup)
  std::map<int, long> first_rows_;                           // the line of each setup's first row
  std::array<int, kNumColumns> index_{};                     // file column index of each known column, -1 if absent
  bool columns_fixed_ = false;                               // set at the columns line or the first sample
  bool header_done_ = false;                                 // set at the first sample
  long line_no_ = 0;
};

}  // namespace

PointsData ParsePoints(std::istream& in, const std::string& source) {
  PointsParser parser(source);
  TextLines lines(in, source, "a points file");
  std::string line;
  while (lines.Next(line)) parser.Line(Trim(line), lines.line_no(), LineError(lines.Where()));
  return parser.Finish();
}

namespace {

// Why "# key: value" would not be the header field (key, value) in a file: "" when it would.
std::string HeaderFieldProblem(const std::string& key, const std::string& value) {
  if (!IsHeaderKey(key)) {
    return "header key " + Quoted(key) +
           " is not a header key (a name of letters, digits, '_' and '-', then '@' and a setup id for a "
           "setup's field)";
  }
  if (value.find_first_of("\n\r") != std::string::npos) {
    return key + ": " + Quoted(value) +
           " holds a line break: a header field is one line (the rest would be read as lines of their own)";
  }
  return "";
}

}  // namespace

PointsData PointsFromColumns(const std::vector<HeaderField>& header, const PointsColumns& columns,
                             const std::string& source) {
  PointsParser parser(source);
  long line = 1;
  const auto where = [&] { return LineError(source + ":" + std::to_string(line) + ": "); };
  parser.Line("# sph-points " + std::to_string(kPointsFormatVersion), line, where());
  for (const HeaderField& f : header) {
    if (f.key == kColumnsKey) continue;  // the columns given say which there are
    ++line;
    const std::string problem = HeaderFieldProblem(f.key, f.value);
    if (!problem.empty()) where()(problem);
    parser.Line("# " + f.key + ": " + f.value, line, where());
  }
  ++line;
  parser.Line(std::string("# ") + kColumnsKey + ": theta_deg phi_deg r_mm" + (columns.t_s != nullptr ? " t_s" : "") +
                  (columns.setup != nullptr ? " setup" : ""),
              line, where());
  parser.ColumnSamples(columns);
  return parser.Finish();
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
    constexpr double kTurnRad = 6.2832, kHalfTurnRad = 3.1416;  // rounded up
    // A measurement in degrees turns Theta through far more than 6.3 deg; one in radians stays within it.
    if (t_hi - t_lo > 1.0 && t_lo >= -kTurnRad && t_hi <= kTurnRad && p_lo >= -0.01 && p_hi <= kHalfTurnRad) {
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
  // Readings no point of the sphere can give: farther from the median reading than its diameter
  // (the largest sphere's, when setups measured other spheres).
  if (data.header.sphere_radius_mm && !data.samples.empty()) {
    double radius_mm = *data.header.sphere_radius_mm;
    for (const auto& [setup, other_mm] : data.header.sphere_radii_mm) radius_mm = std::max(radius_mm, other_mm);
    std::vector<double> r;
    r.reserve(data.samples.size());
    for (const Sample& s : data.samples) r.push_back(s.r_mm);
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
    const double median = r[r.size() / 2];
    const double limit = 2.0 * radius_mm;
    std::vector<std::size_t> far;
    for (std::size_t i = 0; i < data.samples.size(); ++i) {
      if (std::abs(data.samples[i].r_mm - median) > limit) far.push_back(i);
    }
    if (!far.empty()) {
      std::string list;
      for (std::size_t k = 0; k < far.size() && k < 3; ++k) {
        list += (k > 0 ? "; " : "") + data.WhereIs(far[k]) + ": r_mm " +
                internal::Format("%.10g", data.samples[far[k]].r_mm);
      }
      if (far.size() > 3) list += "; and " + std::to_string(far.size() - 3) + " more";
      out.push_back(std::to_string(far.size()) + " probe reading(s) lie farther from the median reading (" +
                    internal::Format("%.6g", median) + " mm) than the sphere's diameter (" +
                    internal::Format("%g", limit) + " mm): gross errors, which a fit leaves out: " + list);
    }
  }
  if (repeats > 0) {
    out.push_back(data.source + ": " + std::to_string(repeats) +
                  " sample(s) repeat an earlier one exactly (the first: " + "sample " + std::to_string(first + 1) +
                  "); a repeated reading counts twice in a fit");
  }
  return out;
}

std::vector<HeaderDevice> DevicesOf(const std::vector<std::pair<std::string, std::string>>& metadata) {
  constexpr std::string_view kPrefix = "device_";
  std::vector<HeaderDevice> out;
  for (const auto& [key, value] : metadata) {
    if (key.size() <= kPrefix.size() || key.compare(0, kPrefix.size(), kPrefix) != 0) continue;
    HeaderDevice d;
    d.role = key.substr(kPrefix.size());
    // Items separated by "; " (a name is quoted and holds no quote: the daemon replaces them).
    std::size_t at = 0;
    while (at < value.size()) {
      std::size_t end = value.find("; ", at);
      if (end == std::string::npos) end = value.size();
      const std::string item = value.substr(at, end - at);
      at = end + 2;
      const std::size_t space = item.find(' ');
      const std::string k = item.substr(0, space);
      std::string v = space == std::string::npos ? "" : item.substr(space + 1);
      if (k == "name" && v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
      std::string* field = k == "node"           ? &d.node
                           : k == "name"         ? &d.name
                           : k == "vendor_id"    ? &d.vendor_id
                           : k == "product_code" ? &d.product_code
                           : k == "revision"     ? &d.revision
                           : k == "serial"       ? &d.serial
                                                 : nullptr;
      if (field && !v.empty()) {
        *field = v;
      } else if (!item.empty()) {
        d.other.push_back(item);
      }
    }
    out.push_back(std::move(d));
  }
  return out;
}

SphereConditions ConditionsOf(const PointsHeader& header) {
  SphereConditions c;
  for (const auto& [key, value] : header.metadata) {
    for (const ConditionField& f : kConditionFields) {
      if (key == f.key) c.*f.field = ParseNumber(value, key, "header");
    }
  }
  return c;
}

std::vector<FixedParameter> FixedParametersOf(const PointsHeader& header) {
  std::vector<FixedParameter> out;
  for (const auto& [key, value] : header.metadata) {
    if (key == kFixKey) out = ParseFixedParameters(value, "header " + key);
  }
  return out;
}

std::vector<ParameterPrior> ParameterPriorsOf(const PointsHeader& header) {
  std::vector<ParameterPrior> out;
  for (const auto& [key, value] : header.metadata) {
    if (key == kPriorKey) out = ParseParameterPriors(value, "header " + key);
  }
  return out;
}

void WritePoints(std::ostream& out, const PointsData& data) {
  for (const auto& [key, value] : data.header.metadata) {
    const std::string problem = HeaderFieldProblem(key, value);
    if (!problem.empty()) throw Error(data.source + ": " + problem);
  }
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
  out << SetupFieldLines(data.header);
  for (const auto& [key, value] : data.header.metadata) out << "# " << key << ": " << value << "\n";
  out << "# " << kColumnsKey << ": theta_deg phi_deg r_mm" << (data.has_time ? " t_s" : "")
      << (data.has_setup ? " setup" : "") << "\n";
  // 10 decimals: 1e-10 deg (2 pm of arc at 20 mm) and 0.1 pm in r, far below any instrument.
  for (const Sample& s : data.samples) out << PointsWriter::FormatRow(s, data.has_time, data.has_setup);
}

void WritePointsFile(const std::string& path, const PointsData& data) {
  WriteFileAtomically(path, [&](std::ostream& out) { WritePoints(out, data); });
}

std::vector<MotionDirection> MotionDirections(const std::vector<Sample>& samples) {
  std::vector<MotionDirection> out(samples.size());
  // Per setup and axis: the previous row's reading, the direction of the last move, and the rows
  // before the first move, which take its direction.
  struct Axis {
    double last = 0.0;
    int direction = 0;
    std::vector<std::size_t> waiting;
  };
  struct Setup {
    bool started = false;
    Axis axes[2];
  };
  std::map<int, Setup> setups;
  auto step = [&](Axis& a, bool started, double value, std::size_t i, int MotionDirection::*field) {
    const double move = std::remainder(value - a.last, 360.0);  // the shorter way round
    if (started && std::abs(move) > kStandstillDeg) {
      a.direction = move > 0.0 ? 1 : -1;
      for (const std::size_t w : a.waiting) out[w].*field = a.direction;
      a.waiting.clear();
    }
    if (a.direction == 0) {
      a.waiting.push_back(i);
    } else {
      out[i].*field = a.direction;
    }
    a.last = value;
  };
  for (std::size_t i = 0; i < samples.size(); ++i) {
    Setup& s = setups[samples[i].setup];
    step(s.axes[0], s.started, samples[i].theta_deg, i, &MotionDirection::theta);
    step(s.axes[1], s.started, samples[i].phi_deg, i, &MotionDirection::phi);
    s.started = true;
  }
  for (const auto& setup : setups) {
    for (const std::size_t w : setup.second.axes[0].waiting) out[w].theta = 1;
    for (const std::size_t w : setup.second.axes[1].waiting) out[w].phi = 1;
  }
  return out;
}

}  // namespace sph
