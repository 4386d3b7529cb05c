// The laboratory's settings of a certificate (sph/io/dcc.hpp): what ParseSettings() keeps and
// what it refuses at its line.
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "sph/io/dcc.hpp"

namespace sph::dcc {
namespace {

using ::testing::HasSubstr;

std::string ErrorOf(const std::string& text) {
  std::istringstream in(text);
  try {
    ParseSettings(in, "lab.txt");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(DccSettings, KeepsEachValueWithItsLine) {
  std::istringstream in("# the lab\n\nlaboratory_name: Caf\xC3\xA9 metrology\ncountry_code: DE\n");
  const Settings s = ParseSettings(in, "lab.txt");
  ASSERT_EQ(s.fields.size(), 2u);
  EXPECT_EQ(s.fields[0].key, "laboratory_name");
  EXPECT_EQ(s.fields[0].value, "Caf\xC3\xA9 metrology");
  EXPECT_EQ(s.fields[0].where, "lab.txt:3");
  EXPECT_EQ(s.fields[1].where, "lab.txt:4");
}

TEST(DccSettings, RefusesAValueThatIsNotTextOfOneLineAtItsLine) {
  // The certificate is UTF-8 XML, which holds no control character.
  EXPECT_THAT(ErrorOf("laboratory_name: ok\nlaboratory_name_2: x\n"), HasSubstr("lab.txt:2: unknown key"));
  const std::string cr = ErrorOf("laboratory_name: 00borat\ro62\n");
  EXPECT_THAT(cr, HasSubstr("lab.txt:1: laboratory_name: "));
  EXPECT_THAT(cr, HasSubstr("holds a control character (0x0D at character 8): a value is text of one line"));
  EXPECT_THAT(ErrorOf("# x\nlaboratory_name: a\x1b[2J\n"), HasSubstr("lab.txt:2: laboratory_name: "));
  EXPECT_THAT(ErrorOf("laboratory_name: caf\xE9\n"),
              HasSubstr("is not UTF-8 text (the byte 0xE9 at character 4): save the file as UTF-8"));
}

}  // namespace
}  // namespace sph::dcc
