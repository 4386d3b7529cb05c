#include "sph/can/candump_log.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include "sph/core/error.hpp"

namespace sph::can {
namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// Parses the frame token "id#data" (can-utils' parse_canframe rules for classic frames).
bool ParseFrameToken(std::string_view tok, CanFrame& f, std::string& error) {
  const auto hash = tok.find('#');
  if (hash == std::string_view::npos) {
    error = "expected 'id#data', got '" + std::string(tok) + "'";
    return false;
  }
  const std::string_view id_text = tok.substr(0, hash);
  if (id_text.size() != 3 && id_text.size() != 8) {
    error = "CAN id '" + std::string(id_text) + "' must have 3 (11 bit) or 8 (29 bit) hex digits";
    return false;
  }
  std::uint32_t id = 0;
  for (char c : id_text) {
    const int v = HexValue(c);
    if (v < 0) {
      error = "CAN id '" + std::string(id_text) + "' is not hexadecimal";
      return false;
    }
    id = (id << 4) | static_cast<std::uint32_t>(v);
  }
  if (id_text.size() == 3) {
    if (id > kSffMask) {
      error = "11-bit CAN id '" + std::string(id_text) + "' is larger than 7FF";
      return false;
    }
  } else if ((id & kErrFlag) == 0) {
    id = (id & kEffMask) | kEffFlag;
  } else {
    id &= kErrFlag | kErrMask;
  }
  f.id = id;
  f.len = 0;
  f.data.fill(0);
  std::string_view rest = tok.substr(hash + 1);
  if (!rest.empty() && rest[0] == '#') {
    error = "CAN FD frames ('##') are not supported";
    return false;
  }
  if (!rest.empty() && (rest[0] == 'R' || rest[0] == 'r')) {
    if ((f.id & kErrFlag) != 0) {  // the kernel never reports one, and no log could carry it back
      error = "an error frame cannot be a remote frame: '" + std::string(tok) + "'";
      return false;
    }
    f.id |= kRtrFlag;
    if (rest.size() == 2 && rest[1] >= '0' && rest[1] <= '8') {
      f.len = static_cast<std::uint8_t>(rest[1] - '0');
    } else if (rest.size() != 1) {
      error = "bad remote frame '" + std::string(tok) + "'";
      return false;
    }
    return true;
  }
  std::size_t i = 0;
  while (i < rest.size()) {
    if (rest[i] == '.') {
      ++i;
      continue;
    }
    if (i + 1 >= rest.size() || HexValue(rest[i]) < 0 || HexValue(rest[i + 1]) < 0) {
      error = "bad data byte '" + std::string(rest.substr(i, 2)) + "'";
      return false;
    }
    if (f.len == kMaxDataBytes) {
      error = "more than 8 data bytes";
      return false;
    }
    f.data[f.len++] = static_cast<std::uint8_t>(HexValue(rest[i]) * 16 + HexValue(rest[i + 1]));
    i += 2;
  }
  return true;
}

}  // namespace

std::string FormatCandumpLine(const CanFrame& frame, std::string_view iface) {
  const std::int64_t us = frame.t_ns / 1000;
  char head[48];
  const int n = std::snprintf(head, sizeof head, "(%010lld.%06lld) ", static_cast<long long>(us / 1000000),
                              static_cast<long long>(us % 1000000));
  std::string line(head, static_cast<std::size_t>(n));
  line.append(iface);
  line += ' ';
  line += ToString(frame);
  return line;
}

bool ParseCandumpLine(std::string_view line, CanFrame& f, std::string& iface, std::string& error) {
  std::size_t i = 0;
  while (i < line.size() && IsSpace(line[i])) ++i;
  if (i >= line.size() || line[i] != '(') {
    error = "expected '(seconds.microseconds)' at the start";
    return false;
  }
  ++i;
  std::int64_t sec = 0, frac = 0;
  int sec_digits = 0, frac_digits = 0;
  while (i < line.size() && line[i] >= '0' && line[i] <= '9' && sec_digits < 12) {
    sec = sec * 10 + (line[i++] - '0');
    ++sec_digits;
  }
  if (sec_digits == 0 || i >= line.size() || line[i] != '.') {
    error = "expected '(seconds.microseconds)' at the start";
    return false;
  }
  ++i;
  while (i < line.size() && line[i] >= '0' && line[i] <= '9') {
    if (frac_digits < 9) {
      frac = frac * 10 + (line[i] - '0');
      ++frac_digits;
    }
    ++i;
  }
  if (frac_digits == 0 || i >= line.size() || line[i] != ')') {
    error = "expected '(seconds.microseconds)' at the start";
    return false;
  }
  ++i;
  // The time in ns must fit in 64 bits: up to the year 2262.
  constexpr std::int64_t kMaxSeconds = std::numeric_limits<std::int64_t>::max() / 1000000000 - 1;
  if (sec > kMaxSeconds) {
    error = "time " + std::to_string(sec) + " s is out of range (at most " + std::to_string(kMaxSeconds) + ")";
    return false;
  }
  for (int d = frac_digits; d < 9; ++d) frac *= 10;
  f.t_ns = sec * 1000000000 + frac;
  // interface
  while (i < line.size() && IsSpace(line[i])) ++i;
  std::size_t j = i;
  while (j < line.size() && !IsSpace(line[j])) ++j;
  if (j == i) {
    error = "no interface name";
    return false;
  }
  iface.assign(line.substr(i, j - i));
  // frame
  i = j;
  while (i < line.size() && IsSpace(line[i])) ++i;
  j = i;
  while (j < line.size() && !IsSpace(line[j])) ++j;
  if (j == i) {
    error = "no frame after the interface name";
    return false;
  }
  if (!ParseFrameToken(line.substr(i, j - i), f, error)) return false;
  // candump -l may add nothing else for classic frames; anything else is foreign.
  while (j < line.size() && IsSpace(line[j])) ++j;
  if (j != line.size()) {
    error = "unexpected text after the frame: '" + std::string(line.substr(j)) + "'";
    return false;
  }
  return true;
}

CandumpReader::CandumpReader(const std::string& path)
    : owned_(std::make_unique<std::ifstream>(path, std::ios::binary)),
      lines_(*owned_, path, "a candump log", TextLines::Nul::kKeep) {
  if (!*owned_) throw Error(path + ": cannot open for reading: " + std::strerror(errno));
}

CandumpReader::CandumpReader(std::istream& in, std::string source)
    : lines_(in, std::move(source), "a candump log", TextLines::Nul::kKeep) {}

CandumpReader::Result CandumpReader::Next() {
  Result r;
  while (lines_.Next(line_)) {
    if (line_.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::string error;
    if (ParseCandumpLine(line_, r.frame, r.iface, error)) {
      r.status = Status::kFrame;
    } else {
      r.status = Status::kMalformed;
      r.error = lines_.Where() + error;
    }
    return r;
  }
  r.status = Status::kEnd;
  return r;
}

namespace {

std::string TimeText(std::int64_t t_ns) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%lld.%06lld", static_cast<long long>(t_ns / 1000000000),
                static_cast<long long>(t_ns % 1000000000 / 1000));
  return buf;
}

// "can0 (from line 1) and can1 (from line 3)", the first eight.
std::string InterfaceList(const std::vector<std::string>& names, const std::map<std::string, std::int64_t>& first) {
  std::string s;
  const std::size_t shown = std::min<std::size_t>(names.size(), 8);
  for (std::size_t i = 0; i < shown; ++i) {
    if (i > 0) s += i + 1 == names.size() ? " and " : ", ";
    s += names[i] + " (from line " + std::to_string(first.at(names[i])) + ")";
  }
  if (shown < names.size()) s += " and " + std::to_string(names.size() - shown) + " more";
  return s;
}

}  // namespace

ReplaySource CheckReplayLog(const std::string& path, const std::string& iface, const std::string& option) {
  CandumpReader reader(path);
  ReplaySource source;
  std::map<std::string, std::int64_t> first_line;
  std::string first_problem;
  std::uint64_t frames = 0;
  std::int64_t last_ns = 0, last_line = 0;
  for (;;) {
    const CandumpReader::Result r = reader.Next();
    if (r.status == CandumpReader::Status::kEnd) break;
    if (r.status == CandumpReader::Status::kMalformed && first_problem.empty()) first_problem = r.error;
    if (r.status != CandumpReader::Status::kFrame) continue;
    ++frames;
    if (first_line.emplace(r.iface, reader.line_number()).second) source.interfaces.push_back(r.iface);
    if (!iface.empty() && r.iface != iface) continue;
    if (iface.empty() && r.iface != source.interfaces.front()) continue;  // several: refused below
    // The SYNC window and the master's timeouts need the receive order to be the time order.
    if (source.frames++ > 0 && r.frame.t_ns < last_ns) {
      throw Error(path + ":" + std::to_string(reader.line_number()) + ": the time " + TimeText(r.frame.t_ns) +
                  " s is before the " + TimeText(last_ns) + " s of line " + std::to_string(last_line) +
                  ": a candump log is in time order (logs merged or edited?)");
    }
    last_ns = r.frame.t_ns;
    last_line = reader.line_number();
  }
  if (frames == 0) {
    const std::int64_t lines = reader.line_number();
    if (lines == 0) throw Error(path + ": empty: no CAN frame to replay");
    if (first_problem.empty()) throw Error(path + ": no CAN frame to replay, only blank lines");
    throw Error(path + ": no CAN frame in its " + std::to_string(lines) + (lines == 1 ? " line" : " lines") +
                ": not a candump log (first: " + first_problem + ")");
  }
  if (iface.empty() && source.interfaces.size() > 1) {
    throw Error(path + ": frames of " + std::to_string(source.interfaces.size()) + " interfaces, " +
                InterfaceList(source.interfaces, first_line) + ": choose one" +
                (option.empty() ? std::string() : " with " + option));
  }
  if (source.frames == 0) {
    throw Error(path + ": no frame of interface " + iface + " (the log holds " +
                InterfaceList(source.interfaces, first_line) + ")");
  }
  source.iface = iface.empty() ? source.interfaces.front() : iface;
  source.other_frames = frames - source.frames;
  return source;
}

void CandumpWriter::CheckContinuable(const std::string& path) {
  AppendFile::CheckTarget(path);
  const std::string text = AppendFile::ReadStart(path, 4096);
  if (text.empty()) return;
  const std::size_t newline = text.find('\n');
  std::string why;
  if (newline == std::string::npos) {
    if (text[0] == '(') return;  // a line cut short by a crash of an earlier run: cut off
    why = "expected '(seconds.microseconds)' at the start";
  } else {
    CanFrame frame;
    std::string iface;
    if (ParseCandumpLine(std::string_view(text).substr(0, newline), frame, iface, why)) return;
  }
  throw Error(path + ": is not a candump log (line 1: " + why + "): refusing to append to it; use another file");
}

namespace {
const std::string& Checked(const std::string& path) {
  CandumpWriter::CheckContinuable(path);
  return path;
}
}  // namespace

CandumpWriter::CandumpWriter(const std::string& path, std::string iface, double fsync_interval_s)
    : file_(Checked(path), fsync_interval_s), iface_(std::move(iface)) {}

void CandumpWriter::Write(const CanFrame& frame) {
  pending_ += FormatCandumpLine(frame, iface_);
  pending_ += '\n';
  ++frames_;
  if (pending_.size() >= 65536) Flush();
}

void CandumpWriter::Flush() {
  if (!pending_.empty()) {
    file_.Append(pending_);
    pending_.clear();
  }
  file_.SyncIfDue();
}

void CandumpWriter::Close() {
  Flush();
  file_.Close();
}

}  // namespace sph::can
