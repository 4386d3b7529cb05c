// The reading of JSON inputs (src/io/json_input.hpp), with bounds small enough to test.
#include "json_input.hpp"

#include <sstream>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph::internal {
namespace {

std::string ErrorOf(const std::string& text, std::size_t max_bytes = 1000) {
  std::istringstream in(text);
  try {
    ParseJsonInput(in, "x.json", "a test file", max_bytes);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ParseJsonInput, ReadsAValueWithinItsBounds) {
  std::istringstream in(R"({"a": [1, {"b": "c"}], "d": {"a": 2}})");
  const nlohmann::json j = ParseJsonInput(in, "x.json", "a test file", 1000);
  EXPECT_EQ(j["a"][1]["b"], "c");
  EXPECT_EQ(j["d"]["a"], 2);  // one key in two objects
  EXPECT_EQ(ErrorOf(std::string(kMaxJsonDepth + 0u, '[') + std::string(kMaxJsonDepth + 0u, ']'), 10000), "");
}

TEST(ParseJsonInput, RefusesWhatIsLargerThanItsBound) {
  EXPECT_EQ(ErrorOf("[" + std::string(998, ' ') + "]"), "");
  EXPECT_EQ(ErrorOf("[" + std::string(999, ' ') + "]"), "x.json: longer than 1000 bytes: this is not a test file");
  // An endless stream is read to the bound and no further.
  sph::testing::RepeatedBytes spaces(' ', std::size_t{64} << 20);
  std::istream in(&spaces);
  EXPECT_THROW(ParseJsonInput(in, "x.json", "a test file", 1 << 20), Error);
  EXPECT_LE(spaces.consumed(), (std::size_t{1} << 20) + (std::size_t{1} << 16));
}

TEST(ParseJsonInput, RefusesNestingBeyondItsBoundAndKeysGivenTwice) {
  EXPECT_EQ(ErrorOf(std::string(kMaxJsonDepth + 1u, '[') + std::string(kMaxJsonDepth + 1u, ']'), 10000),
            "x.json: arrays and objects nested deeper than 64 levels (at '[0][0][0][0][0][0][0][0][0][0][0][0][0][...' "
            "(192 characters)): this is not a test file");
  EXPECT_EQ(ErrorOf(R"({"a": [1, {"b": 1, "c": 2, "b": 3}]})"),
            "x.json: key 'a[1].b' is given twice (JSON would keep one of them silently): give each key once");
  EXPECT_EQ(ErrorOf(R"({"a": 1, "\u0061": 2})"),
            "x.json: key 'a' is given twice (JSON would keep one of them silently): give each key once");
}

TEST(ParseJsonInput, CutsTheParsersMessage) {
  const std::string message = ErrorOf("\"" + std::string(900, 'x'));
  EXPECT_EQ(message.rfind("x.json: not valid JSON: [json.exception.parse_error.101] parse error", 0), 0u) << message;
  EXPECT_LT(message.size(), 300u);
}

TEST(JsonExcerpt, QuotesAnExcerptNeverTheWhole) {
  EXPECT_EQ(JsonExcerpt(nlohmann::json("probe_gain")), "\"probe_gain\"");
  EXPECT_EQ(JsonExcerpt(nlohmann::json(std::string(50, 'y'))), "\"" + std::string(40, 'y') + "\"... (50 characters)");
  EXPECT_EQ(JsonExcerpt(nlohmann::json(1.5)), "1.5");
  EXPECT_EQ(JsonExcerpt(nlohmann::json(nullptr)), "null");
  EXPECT_EQ(JsonExcerpt(nlohmann::json::array({1, 2})), "an array of 2 values");
  EXPECT_EQ(JsonExcerpt(nlohmann::json::object({{"a", 1}})), "an object of 1 key");
}

}  // namespace
}  // namespace sph::internal
