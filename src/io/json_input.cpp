#include "json_input.hpp"

#include <algorithm>
#include <cstring>
#include <set>
#include <vector>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::internal {
namespace {

using nlohmann::json;

// The whole of `in`, at most `max_bytes`, refused at the first NUL byte.
std::string ReadText(std::istream& in, const std::string& source, const std::string& kind, std::size_t max_bytes) {
  std::string text;
  std::vector<char> piece(std::size_t{1} << 16);
  while (in) {
    in.read(piece.data(), static_cast<std::streamsize>(piece.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (in.bad()) throw Error(source + ": read error");
    if (const void* nul = std::memchr(piece.data(), '\0', got)) {
      const auto at = static_cast<std::size_t>(static_cast<const char*>(nul) - piece.data());
      const long line =
          1 + std::count(text.begin(), text.end(), '\n') + std::count(piece.data(), piece.data() + at, '\n');
      throw Error(source + ":" + std::to_string(line) + ": binary data (NUL byte): this is not " + kind);
    }
    if (text.size() + got > max_bytes) {
      throw Error(source + ": longer than " + std::to_string(max_bytes) + " bytes: this is not " + kind);
    }
    text.append(piece.data(), got);
  }
  return text;
}

// Where the parser is: one entry per array or object open around it.
struct Level {
  bool object = false;
  std::set<std::string> keys;  // of an object, those read so far
  std::string key;             // of an object, the key of the value being read
  std::size_t index = 0;       // of an array, the index of the value being read
};

// "geometry.alpha", "effects[0].parameters[1].name": the value being read.
std::string PathOf(const std::vector<Level>& levels) {
  std::string path;
  for (const Level& l : levels) {
    path += l.object ? (path.empty() ? "" : ".") + l.key : "[" + std::to_string(l.index) + "]";
  }
  return path;
}

}  // namespace

json ParseJsonInput(std::istream& in, const std::string& source, const std::string& kind, std::size_t max_bytes) {
  const std::string text = ReadText(in, source, kind, max_bytes);
  std::vector<Level> levels;
  const auto done = [&] {  // a value ended: the next one of its array
    if (!levels.empty() && !levels.back().object) ++levels.back().index;
  };
  const json::parser_callback_t check = [&](int, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        if (levels.size() >= static_cast<std::size_t>(kMaxJsonDepth)) {
          throw Error(source + ": arrays and objects nested deeper than " + std::to_string(kMaxJsonDepth) +
                      " levels (at " + Quoted(PathOf(levels)) + "): this is not " + kind);
        }
        levels.push_back({event == json::parse_event_t::object_start, {}, {}, 0});
        break;
      case json::parse_event_t::key:
        levels.back().key = parsed.get<std::string>();
        if (!levels.back().keys.insert(levels.back().key).second) {
          throw Error(source + ": key " + Quoted(PathOf(levels)) +
                      " is given twice (JSON would keep one of them silently): give each key once");
        }
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        levels.pop_back();
        done();
        break;
      case json::parse_event_t::value:
        done();
        break;
    }
    return true;
  };
  try {
    return json::parse(text, check);  // the whole text: one JSON value and nothing after it
  } catch (const json::exception& e) {
    // The parser's message quotes the token it stopped at, which may be the rest of the file.
    constexpr std::size_t kShown = 240;
    const std::string what = e.what();
    throw Error(source + ": not valid JSON: " + (what.size() > kShown ? what.substr(0, kShown) + "... (cut)" : what));
  }
}

std::string JsonExcerpt(const json& value) {
  if (value.is_string()) {
    // As JSON writes it ("theta_encoder"), cut as Quoted() cuts (a cut UTF-8 character is replaced).
    constexpr std::size_t kShown = 40;
    const std::string& s = value.get_ref<const std::string&>();
    if (s.size() <= kShown) return value.dump(-1, ' ', false, json::error_handler_t::replace);
    return json(s.substr(0, kShown)).dump(-1, ' ', false, json::error_handler_t::replace) + "... (" +
           std::to_string(s.size()) + " characters)";
  }
  if (value.is_array()) {
    return "an array of " + std::to_string(value.size()) + (value.size() == 1 ? " value" : " values");
  }
  if (value.is_object()) {
    return "an object of " + std::to_string(value.size()) + (value.size() == 1 ? " key" : " keys");
  }
  return value.dump();  // a number, true, false or null: short
}

}  // namespace sph::internal
