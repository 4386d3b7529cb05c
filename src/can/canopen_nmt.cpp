// NMT, SYNC, heartbeat and EMCY frames (CiA 301).
#include "sph/can/canopen.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

bool IsPlainSff(const CanFrame& f) { return !f.IsExtended() && !f.IsRemote() && !f.IsError(); }

const char* EmergencyClass(std::uint16_t code) {
  switch (code & 0xFFF0) {  // the specific codes the devices of an SCMS send
    case 0x8110:
      return "communication: CAN overrun (objects lost)";
    case 0x8120:
      return "communication: CAN in error passive mode";
    case 0x8130:
      return "communication: life guard or heartbeat error";
    case 0x8140:
      return "communication: recovered from bus off";
    case 0x8150:
      return "communication: CAN-ID collision";
    case 0x8210:
      return "protocol: PDO not processed due to length error";
    case 0x8220:
      return "protocol: PDO length exceeded";
    case 0x8240:
      return "protocol: unexpected SYNC data length";
    case 0x8250:
      return "protocol: RPDO timeout";
    default:
      break;
  }
  switch (code >> 8) {
    case 0x00:
      return "error reset or no error";
    case 0x10:
      return "generic error";
    case 0x20:
    case 0x21:
    case 0x22:
    case 0x23:
      return "current";
    case 0x30:
    case 0x31:
    case 0x32:
    case 0x33:
      return "voltage";
    case 0x40:
    case 0x41:
    case 0x42:
      return "temperature";
    case 0x50:
      return "device hardware";
    case 0x60:
    case 0x61:
    case 0x62:
    case 0x63:
      return "device software";
    case 0x70:
      return "additional modules";
    case 0x80:
    case 0x81:
    case 0x82:
      return "monitoring";
    case 0x90:
      return "external error";
    case 0xF0:
      return "additional functions";
    case 0xFF:
      return "device specific";
    default:
      return "unknown class";
  }
}

}  // namespace

std::string NmtStateName(std::uint8_t state) {
  switch (static_cast<NmtState>(state)) {
    case NmtState::kBootUp:
      return "boot-up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre-operational";
  }
  return internal::Format("unknown state 0x%02X", state);
}

std::string NmtCommandName(std::uint8_t command) {
  switch (static_cast<NmtCommand>(command)) {
    case NmtCommand::kStart:
      return "Start remote node";
    case NmtCommand::kStop:
      return "Stop remote node";
    case NmtCommand::kEnterPreOperational:
      return "Enter pre-operational";
    case NmtCommand::kResetNode:
      return "Reset node";
    case NmtCommand::kResetCommunication:
      return "Reset communication";
  }
  return internal::Format("unknown NMT command 0x%02X", command);
}

CanFrame EncodeNmt(NmtCommand command, int node_id) {
  return MakeFrame(kNmtCobId, {static_cast<std::uint8_t>(command), static_cast<std::uint8_t>(node_id)});
}

std::optional<NmtMessage> DecodeNmt(const CanFrame& frame, std::string* error) {
  auto fail = [&](const std::string& why) -> std::optional<NmtMessage> {
    if (error != nullptr) *error = why;
    return std::nullopt;
  };
  if (frame.id != kNmtCobId) return fail("not the NMT id 0x000");
  if (frame.len != 2) return fail(std::to_string(frame.len) + " data bytes, an NMT command has 2");
  const std::uint8_t cs = frame.data[0];
  if (NmtCommandName(cs).rfind("unknown", 0) == 0) return fail(NmtCommandName(cs));
  if (frame.data[1] > 127) return fail("node id " + std::to_string(frame.data[1]) + " is not 0..127");
  return NmtMessage{cs, frame.data[1]};
}

CanFrame EncodeSync(std::optional<std::uint8_t> counter, std::uint32_t cob_id) {
  CanFrame f;
  f.id = cob_id;
  if (counter) {
    f.len = 1;
    f.data[0] = *counter;
  }
  return f;
}

std::optional<SyncInfo> DecodeSync(const CanFrame& frame, std::uint32_t cob_id) {
  if (frame.IsRemote() || frame.IsError() || frame.id != cob_id || frame.len > 1) return std::nullopt;
  SyncInfo s;
  if (frame.len == 1) s.counter = frame.data[0];
  return s;
}

std::uint8_t NextSyncCounter(std::uint8_t counter, std::uint8_t max_counter) {
  return counter >= max_counter ? std::uint8_t{1} : static_cast<std::uint8_t>(counter + 1);
}

int MissedSyncs(std::uint8_t previous, std::uint8_t current, std::uint8_t max_counter) {
  // Counters run 1..max: the distance forward from previous to current, minus the one step.
  const int m = max_counter;
  const int step = ((static_cast<int>(current) - static_cast<int>(previous)) % m + m) % m;
  return step == 0 ? m - 1 : step - 1;
}

std::optional<Heartbeat> DecodeHeartbeat(const CanFrame& frame) {
  if (!IsPlainSff(frame) || frame.len != 1) return std::nullopt;
  const std::uint32_t id = frame.Identifier();
  if (id <= kHeartbeatBase || id > kHeartbeatBase + 127) return std::nullopt;
  return Heartbeat{static_cast<int>(id - kHeartbeatBase), frame.data[0]};
}

CanFrame EncodeHeartbeat(int node_id, NmtState state) {
  return MakeFrame(kHeartbeatBase + static_cast<std::uint32_t>(node_id), {static_cast<std::uint8_t>(state)});
}

bool IsEmergencyId(const CanFrame& frame) {
  const std::uint32_t id = frame.Identifier();
  return IsPlainSff(frame) && id > kEmcyBase && id <= kEmcyBase + 127;
}

std::optional<Emergency> DecodeEmergency(const CanFrame& frame) {
  if (!IsEmergencyId(frame) || frame.len != 8) return std::nullopt;
  Emergency e;
  e.node_id = static_cast<int>(frame.Identifier() - kEmcyBase);
  e.error_code = static_cast<std::uint16_t>(frame.data[0] | (frame.data[1] << 8));
  e.error_register = frame.data[2];
  for (std::size_t i = 0; i < e.manufacturer.size(); ++i) e.manufacturer[i] = frame.data[3 + i];
  return e;
}

CanFrame EncodeEmergency(const Emergency& e) {
  CanFrame f;
  f.id = kEmcyBase + static_cast<std::uint32_t>(e.node_id);
  f.len = 8;
  f.data[0] = static_cast<std::uint8_t>(e.error_code & 0xFF);
  f.data[1] = static_cast<std::uint8_t>(e.error_code >> 8);
  f.data[2] = e.error_register;
  for (std::size_t i = 0; i < e.manufacturer.size(); ++i) f.data[3 + i] = e.manufacturer[i];
  return f;
}

std::string DescribeEmergency(const Emergency& e) {
  return internal::Format("node %d: EMCY 0x%04X (%s), error register 0x%02X, data %02X %02X %02X %02X %02X", e.node_id,
                          e.error_code, EmergencyClass(e.error_code), e.error_register, e.manufacturer[0],
                          e.manufacturer[1], e.manufacturer[2], e.manufacturer[3], e.manufacturer[4]);
}

}  // namespace sph::can
