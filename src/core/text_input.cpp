#include "sph/core/text_input.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstring>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph {

using internal::Quoted;

std::ifstream OpenInputFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) throw Error(path + ": is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open for reading: " + std::strerror(errno));
  return in;
}

bool TextLines::Next(std::string& line) {
  line.clear();
  const long number = line_no_ + 1;
  // In pieces of at most kPiece bytes, each checked as it comes: a NUL or an endless line is
  // refused after kMaxLineBytes at most, whatever follows.
  constexpr std::size_t kPiece = 4096;
  char piece[kPiece + 1];
  bool any = false;
  errno = 0;
  for (;;) {
    in_.getline(piece, sizeof piece);
    if (in_.bad()) {
      throw Error(source_ + ": read error" + (errno != 0 ? std::string(": ") + std::strerror(errno) : std::string()));
    }
    const auto got = static_cast<std::size_t>(in_.gcount());
    // The '\n' ended the piece (and is counted in gcount), or the input ended, or the piece is full.
    const bool ended = !in_.fail() && !in_.eof();
    const std::size_t n = ended ? got - 1 : got;
    any |= got > 0;
    if (nul_ == Nul::kRefuse && std::memchr(piece, '\0', n) != nullptr) {
      throw Error(Where(number) + "binary data (NUL byte): this is not " + kind_);
    }
    if (line.size() + n > kMaxLineBytes) {
      throw Error(Where(number) + "the line is longer than " + std::to_string(kMaxLineBytes) + " bytes: this is not " +
                  kind_);
    }
    line.append(piece, n);
    if (ended || in_.eof()) {
      if (!any) return false;
      complete_ = ended;
      break;
    }
    in_.clear();  // the piece was full: the line goes on
  }
  line_no_ = number;
  if (line_no_ == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
  return true;
}

double ParseNumber(const std::string& token, const std::string& what, const std::string& where) {
  double v = 0.0;
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec == std::errc::result_out_of_range && ptr == last) {
    throw Error(where + what + ": " + Quoted(token) + " is out of the range of a double");
  }
  if (ec != std::errc() || ptr != last) throw Error(where + what + ": " + Quoted(token) + " is not a number");
  if (!std::isfinite(v)) throw Error(where + what + ": " + Quoted(token) + " is not a finite number");
  return v;
}

int ParseInteger(const std::string& token, const std::string& what, const std::string& where) {
  int v = 0;
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec == std::errc::result_out_of_range && ptr == last) {
    throw Error(where + what + ": " + Quoted(token) + " is out of the range of an integer (" + std::to_string(INT_MIN) +
                " to " + std::to_string(INT_MAX) + ")");
  }
  if (ec != std::errc() || ptr != last) throw Error(where + what + ": " + Quoted(token) + " is not an integer");
  return v;
}

std::size_t Utf8CharLength(std::string_view text) {
  if (text.empty()) return 0;
  const auto b = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char lead = b(0);
  if (lead < 0x80) return 1;
  // The second byte's range depends on the lead (no overlong forms, no surrogates, <= U+10FFFF).
  std::size_t length = 0;
  unsigned char lo = 0x80, hi = 0xBF;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) lo = 0xA0;
    if (lead == 0xED) hi = 0x9F;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) lo = 0x90;
    if (lead == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (text.size() < length || b(1) < lo || b(1) > hi) return 0;
  for (std::size_t i = 2; i < length; ++i) {
    if (b(i) < 0x80 || b(i) > 0xBF) return 0;
  }
  return length;
}

std::size_t FirstNonUtf8(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = Utf8CharLength(text.substr(i));
    if (n == 0) return i;
    i += n;
  }
  return std::string_view::npos;
}

std::string NotUtf8Reason(std::string_view text) {
  const std::size_t bad = FirstNonUtf8(text);
  if (bad == std::string_view::npos) return "";
  return internal::Format("is not UTF-8 text (the byte 0x%02X at character %zu)", static_cast<unsigned char>(text[bad]),
                          bad + 1);
}

bool ParseHex(const std::string& token, unsigned long long max, unsigned long long* value) {
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (last - first > 2 && first[0] == '0' && (first[1] == 'x' || first[1] == 'X')) first += 2;
  unsigned long long v = 0;  // from_chars takes no sign for an unsigned type
  const auto [ptr, ec] = std::from_chars(first, last, v, 16);
  if (ec != std::errc() || ptr != last || v > max) return false;
  *value = v;
  return true;
}

}  // namespace sph
