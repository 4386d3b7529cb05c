// Reading the text files sph takes as input (points, x y z, angle patterns, calibrations), one
// way for all: the same checks, the same messages.
#ifndef SPH_CORE_TEXT_INPUT_HPP_
#define SPH_CORE_TEXT_INPUT_HPP_

#include <fstream>
#include <istream>
#include <string>

namespace sph {

/// Opens `path` to be read. Throws sph::Error naming it: "<path>: cannot open for reading: No
/// such file or directory", "<path>: is a directory, not a file".
std::ifstream OpenInputFile(const std::string& path);

/// The lines of a text input, with their numbers, for messages "<source>:<line>: <problem>".
/// A UTF-8 byte-order mark at the start is skipped (editors on some systems write one); a NUL
/// byte is refused as binary data; a read error throws.
class TextLines {
 public:
  /// `kind` names what the file should be, for the message about binary data ("a points file").
  TextLines(std::istream& in, std::string source, std::string kind)
      : in_(in), source_(std::move(source)), kind_(std::move(kind)) {}

  /// The next line (without its '\n'), or false at the end. Throws sph::Error on a read error or
  /// a NUL byte ("points.txt:3: binary data (NUL byte): this is not a points file").
  bool Next(std::string& line);
  /// The number of the line Next() returned last (1 for the first).
  long line_no() const { return line_no_; }
  /// "<source>:<line>: ", the start of a message about the current line.
  std::string Where() const { return Where(line_no_); }
  std::string Where(long line) const { return source_ + ":" + std::to_string(line) + ": "; }
  const std::string& source() const { return source_; }

 private:
  std::istream& in_;
  std::string source_;
  std::string kind_;
  long line_no_ = 0;
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

}  // namespace sph

#endif  // SPH_CORE_TEXT_INPUT_HPP_
