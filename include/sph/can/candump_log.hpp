// can-utils' candump log format, as `candump -l` / `candump -L` write it and canplayer and
// log2asc read it: one frame a line,
//
//   (1700000000.000100) vcan0 181#00100000       classic frame, 11-bit id: 3 hex digits
//   (1700000000.000200) vcan0 12345678#0102      29-bit id: 8 hex digits
//   (1700000000.000300) vcan0 20000040#0000000000000000   error frame: 8 digits with the 0x20000000 flag
//   (1700000000.000400) vcan0 123#R              remote frame ('R', then the length digit if not 0)
//
// The time is seconds.microseconds since the Unix epoch (seconds zero-padded to 10 digits on
// writing). Data bytes are upper-case hex pairs; '.' between bytes is accepted on reading, as
// can-utils accepts it. CAN FD lines ("id##flags data") are refused: the SCMS bus is classic CAN.
#ifndef SPH_CAN_CANDUMP_LOG_HPP_
#define SPH_CAN_CANDUMP_LOG_HPP_

#include <cstdint>
#include <istream>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "sph/can/frame.hpp"
#include "sph/core/text_input.hpp"
#include "sph/io/append_file.hpp"

namespace sph::can {

/// The log line for `frame` on interface `iface`, without the '\n'. The time is frame.t_ns
/// truncated to microseconds.
std::string FormatCandumpLine(const CanFrame& frame, std::string_view iface);

/// Parses one log line into `frame` (time in t_ns) and `iface`. On a defect returns false and
/// puts the reason ("expected '(seconds.microseconds)'", "bad data byte 'G0'", ...) in `error`.
bool ParseCandumpLine(std::string_view line, CanFrame& frame, std::string& iface, std::string& error);

/// Reads a log line by line.
class CandumpReader {
 public:
  enum class Status { kFrame, kMalformed, kEnd };
  struct Result {
    Status status = Status::kEnd;
    CanFrame frame;
    std::string iface;
    std::string error;  ///< for kMalformed: "file.log:12: bad data byte 'G0'"
  };

  /// Opens `path`; throws sph::Error when it cannot.
  explicit CandumpReader(const std::string& path);
  /// Reads from `in` (not owned); `source` names it in messages.
  CandumpReader(std::istream& in, std::string source);

  /// The next frame, or kMalformed for a line that is not one (reading goes on after it; a line
  /// with a NUL byte is one), or kEnd. Empty lines are skipped. A read error, or a line longer
  /// than sph::kMaxLineBytes, throws sph::Error.
  Result Next();
  std::int64_t line_number() const { return lines_.line_no(); }

 private:
  std::unique_ptr<std::istream> owned_;
  TextLines lines_;
  std::string line_;
};

/// What a replay reads of a candump log: the frames of one interface (a log of `candump -l any`
/// holds those of every interface, in one time order).
struct ReplaySource {
  std::string iface;                    ///< the interface replayed
  std::vector<std::string> interfaces;  ///< every interface of the log, in the order they first appear
  std::uint64_t frames = 0;             ///< frames of `iface`
  std::uint64_t other_frames = 0;       ///< frames of the other interfaces (left out)
};

/// Checks that `path` can be replayed and chooses what is: the frames of `iface`, or (when it is
/// empty) of the log's only interface. Throws sph::Error with the reason: the file cannot be read,
/// holds no frame ("log.txt: no CAN frame in its 12 lines: not a candump log (first: ...)"), holds
/// frames of several interfaces and none is chosen ("log.txt: frames of 2 interfaces, can0 (from
/// line 1) and can1 (from line 3): choose one with --replay-iface", `option` naming the choice),
/// none of the chosen one, or the chosen interface's times go back ("log.txt:9: the time ... s is
/// before the ... s of line 8"). Frames of other interfaces may interleave in any time order.
ReplaySource CheckReplayLog(const std::string& path, const std::string& iface, const std::string& option = "");

/// Appends frames to a candump log (AppendFile: never overwrites, whole lines only). Lines are
/// collected in memory and written by Flush(), or when 64 KiB are pending.
/// An existing file is checked before it is opened: one that is not a candump log is refused
/// untouched.
class CandumpWriter {
 public:
  CandumpWriter(const std::string& path, std::string iface, double fsync_interval_s);
  /// Throws the sph::Error the constructor would for the file now at `path` (not a candump log,
  /// a directory, a folder that does not exist), without opening, creating or changing anything.
  static void CheckContinuable(const std::string& path);
  void Write(const CanFrame& frame);
  /// Writes the pending lines (one write()) and syncs when due. Throws sph::Error on failure.
  void Flush();
  void Close();
  std::uint64_t frames_written() const { return frames_; }

 private:
  AppendFile file_;
  std::string iface_;
  std::string pending_;
  std::uint64_t frames_ = 0;
};

}  // namespace sph::can

#endif  // SPH_CAN_CANDUMP_LOG_HPP_
