// Reading the text files sph takes as input (points, x y z, angle patterns, calibrations), one
// way for all: the same checks, the same messages.
#ifndef SPH_CORE_TEXT_INPUT_HPP_
#define SPH_CORE_TEXT_INPUT_HPP_

#include <cstddef>
#include <fstream>
#include <istream>
#include <string>
#include <string_view>

namespace sph {

/// Opens `path` to be read. Throws sph::Error naming it: "<path>: cannot open for reading: No
/// such file or directory", "<path>: is a directory, not a file".
std::ifstream OpenInputFile(const std::string& path);

/// The longest line a text input may have [bytes]: far beyond any line sph writes (a points row
/// of the largest doubles is about 1300 bytes) or a person types, and a bound on what one line
/// costs in memory whatever the input is (/dev/zero, a file without line breaks).
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

/// The lines of a text input, with their numbers, for messages "<source>:<line>: <problem>".
/// A UTF-8 byte-order mark at the start is skipped (editors on some systems write one); a NUL
/// byte is refused as binary data as soon as it is read, before its line ends; a line longer
/// than kMaxLineBytes is refused once that many bytes are read; a read error throws.
class TextLines {
 public:
  /// What a NUL byte is: binary data, refused (the default), or a byte of the line like any
  /// other, for a reader that reports a bad line and goes on (a log whose tail a crash filled
  /// with zeros).
  enum class Nul { kRefuse, kKeep };
  /// `kind` names what the file should be, for the messages ("a points file").
  TextLines(std::istream& in, std::string source, std::string kind, Nul nul = Nul::kRefuse)
      : in_(in), source_(std::move(source)), kind_(std::move(kind)), nul_(nul) {}

  /// The next line (without its '\n'), or false at the end. Throws sph::Error on a read error,
  /// a NUL byte ("points.txt:3: binary data (NUL byte): this is not a points file") or a line too
  /// long ("points.txt:3: the line is longer than 1048576 bytes: this is not a points file").
  bool Next(std::string& line);
  /// The number of the line Next() returned last (1 for the first).
  long line_no() const { return line_no_; }
  /// Whether the line Next() returned last ended with '\n' (false for a last line cut short).
  bool complete() const { return complete_; }
  /// "<source>:<line>: ", the start of a message about the current line.
  std::string Where() const { return Where(line_no_); }
  std::string Where(long line) const { return source_ + ":" + std::to_string(line) + ": "; }
  const std::string& source() const { return source_; }

 private:
  std::istream& in_;
  std::string source_;
  std::string kind_;
  Nul nul_;
  long line_no_ = 0;
  bool complete_ = false;
};

/// A whole token as a finite number; else throws sph::Error "<where><what>: '<token>' is not a
/// number" (or "is out of the range of a double", "is not a finite number"). A long token is cut
/// in the message (sph::internal::Quoted). A leading '+' is accepted.
double ParseNumber(const std::string& token, const std::string& what, const std::string& where);

/// A whole token as an int; else throws sph::Error "<where><what>: '<token>' is not an integer"
/// or "... is out of the range of an integer (-2147483648 to 2147483647)".
int ParseInteger(const std::string& token, const std::string& what, const std::string& where);

/// A whole token as a hexadecimal integer of at most `max`, with or without "0x" ("0x2000",
/// "8130"): true with it in `*value`; false for anything else (a sign, a space, no digit, a larger
/// value), the caller saying what it expected.
bool ParseHex(const std::string& token, unsigned long long max, unsigned long long* value);

/// The length in bytes (1 to 4) of the well-formed UTF-8 character (RFC 3629) that `text` starts
/// with, or 0 when it starts with none: a stray continuation byte, an overlong form, a surrogate, a
/// code point beyond U+10FFFF, or a character cut short by the end of `text`.
std::size_t Utf8CharLength(std::string_view text);

/// The offset of the first byte of `text` that is not part of well-formed UTF-8, or npos when all
/// of it is (what a text of a file must be before a report or a JSON file copies it).
std::size_t FirstNonUtf8(std::string_view text);

/// "is not UTF-8 text (the byte 0xE9 at character 4)" for the first byte of `text` that is not
/// well-formed UTF-8, or "" when all of it is: the reason a reader gives for refusing it.
std::string NotUtf8Reason(std::string_view text);

}  // namespace sph

#endif  // SPH_CORE_TEXT_INPUT_HPP_
