#include "sph/io/points_writer.hpp"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph {
namespace {

std::string Trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return "";
  const auto last = s.find_last_not_of(" \t\r");
  return std::string(s.substr(first, last - first + 1));
}

// Whether "# <body>" would be read as a header field (or the format line).
bool LooksLikeHeaderField(const std::string& body) {
  return body.rfind("sph-points", 0) == 0 || HeaderFieldOf(body).has_value();
}

std::string OneLine(std::string_view text) {
  std::string s(text);
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  return s;
}

std::string ColumnsOf(const PointsWriterOptions& o) {
  return std::string("theta_deg phi_deg r_mm") + (o.has_time ? " t_s" : "") + (o.has_setup ? " setup" : "");
}

// `v` in fixed point with `decimals` (at most 10) decimals, whatever its magnitude.
void AppendFixed(std::string& out, double v, int decimals) {
  char buf[340];  // the longest: sign, 309 digits of the largest double, point, 10 decimals
  const int n = std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  out.append(buf, static_cast<std::size_t>(std::clamp(n, 0, static_cast<int>(sizeof buf) - 1)));
}

// The "key: value" header fields of the whole lines of `text` up to its first sample.
std::map<std::string, std::string> HeaderFields(const std::string& text) {
  std::map<std::string, std::string> fields;
  std::size_t begin = 0;
  for (std::size_t end; (end = text.find('\n', begin)) != std::string::npos; begin = end + 1) {
    const std::string line = Trim(std::string_view(text).substr(begin, end - begin));
    if (line.empty()) continue;
    if (line[0] != '#') break;  // the first sample ends the header
    if (auto f = HeaderFieldOf(std::string_view(line).substr(1))) fields.emplace(f->key, f->value);
  }
  return fields;
}

// What the file at `path` holds of its setups: the per-setup fields ("mount_rotation_deg@<setup>"
// and "sphere_radius_mm@<setup>" to their values) written anywhere in it (in its header, or
// between samples where an appending run wrote those of a new setup), and the line of each
// setup's first row (the setup id is the last column when the file has one, else 0).
struct FileSetups {
  std::map<std::string, std::string> fields;
  std::map<int, long> first_rows;
};

FileSetups SetupsOf(const std::string& path, bool has_setup) {
  FileSetups out;
  std::ifstream in = OpenInputFile(path);
  // NUL bytes are kept: a row holding one is no row of any setup, and the reader names it.
  TextLines lines(in, path, "a points file", TextLines::Nul::kKeep);
  const std::string rotation = std::string(kMountRotationKey) + "@", radius = std::string(kRadiusKey) + "@";
  for (std::string line; lines.Next(line);) {
    const std::string text = Trim(line);
    if (text.empty()) continue;
    if (text[0] == '#') {
      const std::optional<HeaderField> f = HeaderFieldOf(std::string_view(text).substr(1));
      if (f && (f->key.rfind(rotation, 0) == 0 || f->key.rfind(radius, 0) == 0)) out.fields.emplace(f->key, f->value);
      continue;
    }
    if (!lines.complete()) break;  // a row cut short by a crash, cut off when the file is opened
    int setup = 0;
    if (has_setup) {
      const std::string last = text.substr(text.find_last_of(" \t\r") + 1);
      const auto [ptr, ec] = std::from_chars(last.data(), last.data() + last.size(), setup);
      if (ec != std::errc() || ptr != last.data() + last.size()) continue;  // no row: the reader names it
    }
    out.first_rows.emplace(setup, lines.line_no());
  }
  return out;
}

void CheckSameNumber(const std::string& path, const std::map<std::string, std::string>& fields, const char* key,
                     const std::optional<double>& ours) {
  const auto it = fields.find(key);
  if (it == fields.end() || !ours) return;
  char* end = nullptr;
  const double theirs = std::strtod(it->second.c_str(), &end);
  if (end == it->second.c_str() || theirs != *ours) {
    throw Error(path + ": has " + key + " " + it->second + " but this run writes " + internal::Shortest(*ours) +
                ": use another file");
  }
}

}  // namespace

void PointsWriter::CheckContinuable(const std::string& path, const PointsHeader& header,
                                    const PointsWriterOptions& options) {
  Continuable(path, header, options);
}

PointsWriter::SetupFields PointsWriter::Continuable(const std::string& path, const PointsHeader& header,
                                                    const PointsWriterOptions& options) {
  AppendFile::CheckTarget(path);
  const std::string text = AppendFile::ReadStart(path, 1 << 20);
  if (text.empty()) return {};
  const std::string format_line = "# sph-points " + std::to_string(kPointsFormatVersion);
  const std::size_t newline = text.find('\n');
  if (newline == std::string::npos) {
    // A header cut short by a crash of an earlier run is cut off and written again.
    if (format_line.rfind(text, 0) == 0) return {};
  } else if (Trim(std::string_view(text).substr(0, newline)) == format_line) {
    const auto fields = HeaderFields(text);
    const auto it = fields.find(kColumnsKey);
    const std::string columns = ColumnsOf(options);
    const std::string theirs = it == fields.end() ? "theta_deg phi_deg r_mm" : it->second;
    if (theirs != columns) {
      throw Error(path + ": has columns '" + theirs + "' but this run writes '" + columns + "': use another file");
    }
    CheckSameNumber(path, fields, kRadiusKey, header.sphere_radius_mm);
    CheckSameNumber(path, fields, kProbeOffsetKey, header.probe_offset_mm);
    if (header.mount_rotations.empty() && header.sphere_radii_mm.empty()) return {};
    const FileSetups file = SetupsOf(path, options.has_setup);
    SetupFields in_file = file.fields;  // and the fields this run need not write
    // A setup that has rows was recorded with the fields the file gives it, none meaning the
    // reference orientation and sphere: a field now would apply to those rows too.
    const auto rows_of = [&](int setup, const std::string& key, const std::string& were, const std::string& ours) {
      const auto rows = file.first_rows.find(setup);
      if (rows == file.first_rows.end()) return;  // a new setup: its fields are written before its first row
      throw Error(path + ": setup " + std::to_string(setup) + " has rows (the first at line " +
                  std::to_string(rows->second) + ") " + were + " (no " + key + " before them): this run's " + key +
                  " " + ours + " would apply to them too: give this placement a setup of its own");
    };
    for (const auto& [setup, ours] : header.mount_rotations) {
      const std::string key = MountRotationKey(setup);
      const auto field = file.fields.find(key);
      if (field == file.fields.end()) {
        if (SameOrientation(ours, MountRotation::Known(Eigen::Vector3d::Zero()))) {
          in_file.emplace(key, "");  // the reference orientation, which the setup's rows have
        } else {
          rows_of(setup, key, "in the reference orientation", MountRotationValue(ours));
        }
      } else if (!SameOrientation(ParseMountRotation(field->second, key, path + ": "), ours)) {
        throw Error(path + ": has " + key + " " + field->second + " but this run writes " + MountRotationValue(ours) +
                    ": use another file");
      }
    }
    for (const auto& [setup, ours] : header.sphere_radii_mm) {
      const std::string key = SphereRadiusKey(setup);
      if (file.fields.count(key) == 0) {
        rows_of(setup, key, "of the reference sphere", internal::Shortest(ours));
      }
      CheckSameNumber(path, file.fields, key.c_str(), ours);
    }
    return in_file;
  }
  throw Error(path + ": is not a points file (its first line is not '" + format_line +
              "'): refusing to append to it; use another file");
}

PointsWriter::PointsWriter(const std::string& path, const PointsHeader& header, const PointsWriterOptions& options)
    : PointsWriter(path, header, options, Continuable(path, header, options)) {}

PointsWriter::PointsWriter(const std::string& path, const PointsHeader& header, const PointsWriterOptions& options,
                           const SetupFields& in_file)
    : file_(path, options.fsync_interval_s), options_(options) {
  const std::string columns = ColumnsOf(options);
  if (file_.had_content()) {
    resumed_ = true;
    // The fields of a setup the file does not hold yet, before its first row.
    const std::string lines = SetupFieldLines(header, in_file);
    if (!lines.empty()) file_.Append(lines);
    return;
  }
  std::string head = "# sph-points " + std::to_string(kPointsFormatVersion) + "\n";
  if (header.sphere_radius_mm) {
    head += std::string("# ") + kRadiusKey + ": " + internal::Shortest(*header.sphere_radius_mm) + "\n";
  }
  if (header.probe_offset_mm) {
    head += std::string("# ") + kProbeOffsetKey + ": " + internal::Shortest(*header.probe_offset_mm) + "\n";
  }
  head += SetupFieldLines(header);
  for (const auto& [key, value] : header.metadata) {
    if (!IsHeaderKey(key)) throw Error(path + ": '" + key + "' is not a valid header key");
    const std::string name = key.substr(0, key.find('@'));
    if (name == kRadiusKey || name == kProbeOffsetKey || name == kColumnsKey || name == kMountRotationKey) continue;
    head += "# " + key + ": " + OneLine(value) + "\n";
  }
  head += std::string("# ") + kColumnsKey + ": " + columns + "\n";
  file_.Append(head);
}

std::string PointsWriter::FormatRow(const Sample& s, bool has_time, bool has_setup) {
  std::string row;
  row.reserve(64);
  AppendFixed(row, s.theta_deg, 10);
  row += ' ';
  AppendFixed(row, s.phi_deg, 10);
  row += ' ';
  AppendFixed(row, s.r_mm, 10);
  if (has_time) {
    row += ' ';
    AppendFixed(row, s.t_s, 6);
  }
  if (has_setup) {
    row += ' ';
    row += std::to_string(s.setup);
  }
  row += '\n';
  return row;
}

void PointsWriter::Write(const Sample& sample) {
  file_.Append(FormatRow(sample, options_.has_time, options_.has_setup));
  ++samples_written_;
}

void PointsWriter::WriteComment(std::string_view text) {
  std::string body = Trim(OneLine(text));
  if (LooksLikeHeaderField(body)) body = "note " + body;
  file_.Append("# " + body + "\n");
}

}  // namespace sph
