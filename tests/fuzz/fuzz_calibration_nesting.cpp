// libFuzzer target: the calibration file reader (sph::ParseCalibration) on inputs that nest and
// repeat what a JSON file holds. Its mutator wraps a value in up to 131072 arrays or objects,
// or gives a "key": value pair a second time in its object, and else mutates as libFuzzer does:
// byte mutations alone do not nest a value thousands deep, which is where a recursion over the
// value (a message quoting it, a copy) runs out of stack. Run with a -max_len that holds such a
// nesting (fuzz_calibration_nesting.options). What is checked: calibration_check.hpp.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "calibration_check.hpp"

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// The end of the JSON value that starts at `begin` (one past its last byte): a string to its
// closing quote, an array or object to its closing bracket, anything else to the next ',', ']',
// '}' or space; the end of `text` when it does not end.
std::size_t ValueEnd(const std::string& text, std::size_t begin) {
  std::size_t i = begin;
  if (i >= text.size()) return text.size();
  if (text[i] == '"') {
    for (++i; i < text.size(); ++i) {
      if (text[i] == '\\') {
        ++i;
      } else if (text[i] == '"') {
        return i + 1;
      }
    }
    return text.size();
  }
  if (text[i] == '[' || text[i] == '{') {
    int depth = 0;
    bool in_string = false;
    for (; i < text.size(); ++i) {
      const char c = text[i];
      if (in_string) {
        if (c == '\\') {
          ++i;
        } else if (c == '"') {
          in_string = false;
        }
      } else if (c == '"') {
        in_string = true;
      } else if (c == '[' || c == '{') {
        ++depth;
      } else if ((c == ']' || c == '}') && --depth == 0) {
        return i + 1;
      }
    }
    return text.size();
  }
  while (i < text.size() && text[i] != ',' && text[i] != ']' && text[i] != '}' && !IsSpace(text[i])) ++i;
  return i;
}

// The positions where a value starts after a ':' or a '[' (or the text's start).
std::vector<std::size_t> ValueStarts(const std::string& text) {
  std::vector<std::size_t> starts{0};
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != ':' && text[i] != '[') continue;
    std::size_t j = i + 1;
    while (j < text.size() && IsSpace(text[j])) ++j;
    if (j < text.size()) starts.push_back(j);
  }
  return starts;
}

// The positions of keys: a string followed by ':'.
std::vector<std::size_t> KeyStarts(const std::string& text) {
  std::vector<std::size_t> keys;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '"') continue;
    const std::size_t end = ValueEnd(text, i);
    std::size_t j = end;
    while (j < text.size() && IsSpace(text[j])) ++j;
    if (j < text.size() && text[j] == ':') keys.push_back(i);
    i = end - 1;
  }
  return keys;
}

// Wraps the value at a random start in `depth` arrays (or objects of one key).
bool Nest(std::string& text, std::mt19937& rng, std::size_t max_size) {
  const std::vector<std::size_t> starts = ValueStarts(text);
  const std::size_t begin = starts[rng() % starts.size()];
  const std::size_t end = ValueEnd(text, begin);
  const bool objects = rng() % 4 == 0;
  const std::string open = objects ? "{\"k\":" : "[", close = objects ? "}" : "]";
  const std::size_t room = max_size > text.size() ? (max_size - text.size()) / (open.size() + close.size()) : 0;
  const std::size_t depth = std::min<std::size_t>(std::size_t{1} << (rng() % 18), room);
  if (depth == 0) return false;
  std::string opens, closes;
  for (std::size_t k = 0; k < depth; ++k) opens += open;
  for (std::size_t k = 0; k < depth; ++k) closes += close;
  text.insert(end, closes);
  text.insert(begin, opens);
  return true;
}

// Gives a random "key": value pair a second time, after the first (the value kept or another one
// of the text).
bool RepeatKey(std::string& text, std::mt19937& rng, std::size_t max_size) {
  const std::vector<std::size_t> keys = KeyStarts(text);
  if (keys.empty()) return false;
  const std::size_t key = keys[rng() % keys.size()];
  std::size_t value = text.find(':', ValueEnd(text, key)) + 1;
  while (value < text.size() && IsSpace(text[value])) ++value;
  const std::size_t end = ValueEnd(text, value);
  std::string pair = text.substr(key, end - key);
  if (rng() % 2 == 0) {
    const std::vector<std::size_t> starts = ValueStarts(text);
    const std::size_t other = starts[rng() % starts.size()];
    pair = text.substr(key, value - key) + text.substr(other, ValueEnd(text, other) - other);
  }
  if (text.size() + pair.size() + 2 > max_size) return false;
  text.insert(end, ", " + pair);
  return true;
}

}  // namespace

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size, std::size_t max_size,
                                               unsigned int seed) {
  std::mt19937 rng(seed);
  std::string text(reinterpret_cast<const char*>(data), size);
  const unsigned int what = rng() % 4;
  if ((what == 0 && Nest(text, rng, max_size)) || (what == 1 && RepeatKey(text, rng, max_size))) {
    std::memcpy(data, text.data(), text.size());
    return text.size();
  }
  return LLVMFuzzerMutate(data, size, max_size);
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return sph::fuzz::CheckCalibration(data, size);
}
