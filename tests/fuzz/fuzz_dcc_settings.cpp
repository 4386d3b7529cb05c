// libFuzzer target: sph::dcc::ParseSettings (a laboratory's settings of a certificate) on arbitrary
// bytes: every field it keeps has a key of kDccKeys, a value on one line and the line it came from.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sph/core/error.hpp"
#include "sph/io/dcc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const sph::dcc::Settings settings = sph::dcc::ParseSettings(in, "fuzz");
    for (const sph::dcc::Field& f : settings.fields) {
      bool known = false;
      for (const sph::dcc::KeyInfo& k : sph::dcc::kDccKeys) known = known || f.key == k.key;
      if (!known) std::abort();                                            // a key the format has not
      if (f.value.find_first_of("\r\n") != std::string::npos) std::abort();  // a value over lines
      if (f.where.rfind("fuzz:", 0) != 0) std::abort();                    // where it was given
    }
  } catch (const sph::Error&) {
  }
  return 0;
}
