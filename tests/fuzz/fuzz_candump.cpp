// libFuzzer target: candump log lines (sph::can::ParseCandumpLine and CandumpReader). A line that
// parses must be formatted back by FormatCandumpLine to a line that parses to the same frame.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <string_view>

#include "sph/can/candump_log.hpp"
#include "sph/core/error.hpp"

namespace {

bool SameFrame(const sph::can::CanFrame& a, const sph::can::CanFrame& b) {
  // The log keeps microseconds.
  return a.id == b.id && a.len == b.len && a.data == b.data && a.t_ns / 1000 == b.t_ns / 1000;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  sph::can::CanFrame frame;
  std::string iface, error;
  if (sph::can::ParseCandumpLine(text, frame, iface, error)) {
    if (frame.len > sph::can::kMaxDataBytes || iface.empty()) std::abort();
    const std::string line = sph::can::FormatCandumpLine(frame, iface);
    sph::can::CanFrame again;
    std::string again_iface, again_error;
    if (!sph::can::ParseCandumpLine(line, again, again_iface, again_error) || !SameFrame(frame, again) ||
        again_iface != iface) {
      std::abort();
    }
  } else if (error.empty()) {
    std::abort();  // a refused line always says why
  }

  // The same bytes as a whole log.
  std::istringstream in(text);
  sph::can::CandumpReader reader(in, "fuzz.log");
  try {
    for (;;) {
      const auto r = reader.Next();
      if (r.status == sph::can::CandumpReader::Status::kEnd) break;
      if (r.status == sph::can::CandumpReader::Status::kMalformed && r.error.empty()) std::abort();
      if (r.status == sph::can::CandumpReader::Status::kFrame && r.frame.len > sph::can::kMaxDataBytes) std::abort();
    }
  } catch (const sph::Error&) {
  }
  return 0;
}
