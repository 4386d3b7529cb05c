// JSON that comes from outside (a file a user names): read within bounds, so that whatever it
// holds costs no more than a file of its kind can need, and quoted in messages by excerpts.
#ifndef SPH_SRC_IO_JSON_INPUT_HPP_
#define SPH_SRC_IO_JSON_INPUT_HPP_

#include <cstddef>
#include <istream>
#include <string>

#include <nlohmann/json.hpp>

namespace sph::internal {

/// The deepest nesting of arrays and objects a JSON input may have: far beyond any file sph
/// reads (a calibration file nests 5 deep), far below what a recursion over a value (dump(),
/// a copy, a comparison) can take.
inline constexpr int kMaxJsonDepth = 64;

/// Parses `in` as one JSON value and nothing after it. Throws sph::Error naming `source` when it
/// holds a NUL byte ("x.json:3: binary data (NUL byte): this is not <kind>"), is longer than
/// `max_bytes`, is not JSON ("x.json: not valid JSON: ..."), nests arrays and objects deeper
/// than kMaxJsonDepth, or gives one key twice in an object ("x.json: key 'geometry.alpha' is
/// given twice"; a JSON parser would keep one of them silently).
nlohmann::json ParseJsonInput(std::istream& in, const std::string& source, const std::string& kind,
                              std::size_t max_bytes);

/// A value of an input for a message: a string as JSON writes it, cut after 40 characters as
/// Quoted() cuts; a number, true, false or null as written; an array or an object by its size
/// ("an array of 3 values"): never the whole of a value that may be long or deep.
std::string JsonExcerpt(const nlohmann::json& value);

}  // namespace sph::internal

#endif  // SPH_SRC_IO_JSON_INPUT_HPP_
