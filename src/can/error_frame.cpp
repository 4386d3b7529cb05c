#include "sph/can/error_frame.hpp"

#include <cstdio>
#include <utility>

namespace sph::can {
namespace {

void Append(std::string& text, const std::string& item) {
  if (!text.empty()) text += ", ";
  text += item;
}

// "name{a,b}" from the bits of `byte` that have names.
std::string WithDetails(const char* name, std::uint8_t byte,
                        std::initializer_list<std::pair<std::uint8_t, const char*>> bits) {
  std::string details;
  for (const auto& [bit, label] : bits) {
    if ((byte & bit) != 0) details += (details.empty() ? "" : ",") + std::string(label);
  }
  return details.empty() ? std::string(name) : std::string(name) + "{" + details + "}";
}

}  // namespace

std::optional<ErrorFrameInfo> DecodeErrorFrame(const CanFrame& f) {
  if (!f.IsError()) return std::nullopt;
  ErrorFrameInfo e;
  e.classes = f.id & kErrMask;
  auto byte = [&](int i) -> std::uint8_t { return i < f.len ? f.data[static_cast<std::size_t>(i)] : std::uint8_t{0}; };
  if (e.classes & kErrTxTimeout) Append(e.text, "tx-timeout");
  if (e.classes & kErrLostArbitration) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "lost-arbitration{at bit %u}", byte(0));
    Append(e.text, buf);
  }
  if (e.classes & kErrController) {
    const std::uint8_t c = byte(1);
    e.error_passive = (c & 0x30) != 0;
    e.controller_overflow = (c & 0x03) != 0;
    Append(e.text, WithDetails("controller-problem", c,
                               {{0x01, "rx-overflow"},
                                {0x02, "tx-overflow"},
                                {0x04, "rx-error-warning"},
                                {0x08, "tx-error-warning"},
                                {0x10, "rx-error-passive"},
                                {0x20, "tx-error-passive"},
                                {0x40, "back-to-error-active"}}));
  }
  if (e.classes & kErrProtocol) {
    std::string p = WithDetails("protocol-violation", byte(2),
                                {{0x01, "single-bit-error"},
                                 {0x02, "frame-format-error"},
                                 {0x04, "bit-stuffing-error"},
                                 {0x08, "dominant-bit-error"},
                                 {0x10, "recessive-bit-error"},
                                 {0x20, "bus-overload"},
                                 {0x40, "active-error-announcement"},
                                 {0x80, "error-on-tx"}});
    char buf[32];
    std::snprintf(buf, sizeof buf, "{location 0x%02X}", byte(3));
    Append(e.text, p + buf);
  }
  if (e.classes & kErrTransceiver) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "transceiver-status{0x%02X}", byte(4));
    Append(e.text, buf);
  }
  if (e.classes & kErrNoAck) Append(e.text, "no-acknowledgement-on-tx");
  if (e.classes & kErrBusOff) {
    e.bus_off = true;
    Append(e.text, "bus-off");
  }
  if (e.classes & kErrBusError) Append(e.text, "bus-error");
  if (e.classes & kErrRestarted) Append(e.text, "restarted-after-bus-off");
  if (e.classes & kErrCounters) {
    e.tx_error_counter = byte(6);
    e.rx_error_counter = byte(7);
    char buf[48];
    std::snprintf(buf, sizeof buf, "error-counter{tx %u, rx %u}", byte(6), byte(7));
    Append(e.text, buf);
  }
  const std::uint32_t unknown = e.classes & ~std::uint32_t{0x3FF};
  if (unknown != 0) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "unknown-classes{0x%X}", unknown);
    Append(e.text, buf);
  }
  if (e.text.empty()) e.text = "no error class set";
  return e;
}

CanFrame MakeErrorFrame(std::uint32_t classes, std::initializer_list<std::uint8_t> data) {
  CanFrame f = MakeFrame(0, data);
  f.id = kErrFlag | (classes & kErrMask);
  f.len = kMaxDataBytes;  // the kernel always sends CAN_ERR_DLC = 8
  return f;
}

}  // namespace sph::can
