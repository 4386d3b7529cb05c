#include "sph/can/frame.hpp"

#include <cstdio>

namespace sph::can {

CanFrame MakeFrame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, std::int64_t t_ns) {
  CanFrame f;
  f.id = id;
  f.t_ns = t_ns;
  for (std::uint8_t b : bytes) {
    if (f.len == kMaxDataBytes) break;
    f.data[f.len++] = b;
  }
  return f;
}

std::string ToString(const CanFrame& frame) {
  char buf[40];
  int n = 0;
  if (frame.IsError()) {
    n = std::snprintf(buf, sizeof buf, "%08X#", frame.id & (kErrMask | kErrFlag));
  } else if (frame.IsExtended()) {
    n = std::snprintf(buf, sizeof buf, "%08X#", frame.id & kEffMask);
  } else {
    n = std::snprintf(buf, sizeof buf, "%03X#", frame.id & kSffMask);
  }
  std::string out(buf, static_cast<std::size_t>(n));
  if (frame.IsRemote() && !frame.IsError()) {
    out += 'R';
    if (frame.len > 0 && frame.len <= kMaxDataBytes) out += static_cast<char>('0' + frame.len);
    return out;
  }
  static constexpr char kHex[] = "0123456789ABCDEF";
  for (int i = 0; i < frame.len && i < kMaxDataBytes; ++i) {
    out += kHex[frame.data[static_cast<std::size_t>(i)] >> 4];
    out += kHex[frame.data[static_cast<std::size_t>(i)] & 0xF];
  }
  return out;
}

}  // namespace sph::can
