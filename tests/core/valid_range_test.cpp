// The one wording of a refused number (sph/core/valid_range.hpp), for a typed text and for a value.
#include "sph/core/valid_range.hpp"

#include <string>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"

namespace sph {
namespace {

constexpr ValidRange kRadiusMm{0.0, 1000.0, "mm", true};
constexpr ValidRange kPeriodS{0.001, 65.535, "s"};

// The message CheckedValue() or CheckedValueOr() throws, without "<what>: ".
template <typename Check>
std::string Thrown(Check check) {
  try {
    check();
  } catch (const Error& e) {
    const std::string what = e.what();
    return what.substr(what.find(": ") + 2);
  }
  return "";
}

TEST(RefusalOf, AcceptsANumberInTheRange) {
  EXPECT_EQ(RefusalOf("20", kRadiusMm), "");
  EXPECT_EQ(RefusalOf("+1e3", kRadiusMm), "");
  EXPECT_EQ(RefusalOf("0", 0.0, "none", kPeriodS), "");
  EXPECT_EQ(RefusalOf("0.5", 0.0, "none", kPeriodS), "");
}

TEST(RefusalOf, RefusesInTheWordsOfTheLibrarysCheck) {
  EXPECT_EQ(RefusalOf("1e308", kRadiusMm), "must be > 0 and <= 1000 mm, got 1e308");
  EXPECT_EQ(RefusalOf("1e308", kRadiusMm), Thrown([] { CheckedValue(1e308, kRadiusMm, "R", "1e308"); }));
  EXPECT_EQ(RefusalOf("0", kRadiusMm), Thrown([] { CheckedValue(0.0, kRadiusMm, "R"); }));
  EXPECT_EQ(RefusalOf("1e-300", 0.0, "none", kPeriodS), "must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-300");
  EXPECT_EQ(RefusalOf("1e-300", 0.0, "none", kPeriodS),
            Thrown([] { CheckedValueOr(1e-300, 0.0, "none", kPeriodS, "--period-s"); }));
}

TEST(RefusalOf, RefusesWhatIsNotAFiniteNumberWithTheRange) {
  EXPECT_EQ(RefusalOf("inf", kRadiusMm), "must be > 0 and <= 1000 mm, got inf");
  EXPECT_EQ(RefusalOf("20mm", kRadiusMm), "must be > 0 and <= 1000 mm, got 20mm");
  EXPECT_EQ(RefusalOf("", 0.0, "none", kPeriodS), "must be 0 (none) or >= 0.001 and <= 65.535 s, got ");
}

}  // namespace
}  // namespace sph
