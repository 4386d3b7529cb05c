// CANopen frames of an SCMS: SYNC, position TPDOs of CiA 406 rotary encoders, the probe's TPDO,
// heartbeats and EMCY. Pure functions on sph::can::CanFrame; nothing here touches a socket.
//
// Frames (CiA 301 predefined connection set, node id n = 1..127):
//
//   NMT        0x000      2 bytes: [0] command specifier, [1] node id (0: all nodes); §7.2.8.3.1:
//                         0x01 start remote node, 0x02 stop remote node, 0x80 enter
//                         pre-operational, 0x81 reset node, 0x82 reset communication
//   SYNC       0x080      0 bytes, or 1 byte counter 1..max (max 2..240, object 1019h), counting up
//                         and wrapping to 1; §7.2.5
//   EMCY       0x080 + n  8 bytes: [0..1] error code (u16, little endian), [2] error register (0x1001),
//                         [3..7] manufacturer specific. Error code 0x0000 means "error reset / no error".
//   TPDO1      0x180 + n  position value 0x6004 of a CiA 406 encoder (u32 LE), or the probe value
//   Heartbeat  0x700 + n  1 byte NMT state: 0x00 boot-up, 0x04 stopped, 0x05 operational,
//                         0x7F pre-operational (§7.2.8.3.2.2; the boot-up message, §7.2.8.3.3, is
//                         the same frame with 0x00: the node has just (re)started and is now
//                         pre-operational, sending no PDO until an NMT master starts it)
//
// A value inside a PDO is a FieldLayout: `width_bytes` bytes from `offset_byte`, little endian
// (CANopen) unless `big_endian`, unsigned unless `is_signed` (two's complement).
#ifndef SPH_CAN_CANOPEN_HPP_
#define SPH_CAN_CANOPEN_HPP_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sph/can/frame.hpp"

namespace sph::can {

inline constexpr std::uint32_t kNmtCobId = 0x000;
inline constexpr std::uint32_t kSyncCobId = 0x080;
inline constexpr std::uint32_t kEmcyBase = 0x080;
inline constexpr std::uint32_t kTpdo1Base = 0x180;
inline constexpr std::uint32_t kHeartbeatBase = 0x700;

/// NMT states as a heartbeat carries them.
enum class NmtState : std::uint8_t {
  kBootUp = 0x00,
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};

/// "operational", "pre-operational", ..., or "unknown state 0x12".
std::string NmtStateName(std::uint8_t state);

/// NMT node control command specifiers (CiA 301 §7.2.8.3.1).
enum class NmtCommand : std::uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kEnterPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82,
};
/// "Start remote node", ..., or "unknown NMT command 0x12".
std::string NmtCommandName(std::uint8_t command);

struct NmtMessage {
  std::uint8_t command = 0;  ///< NmtCommand value
  int node_id = 0;           ///< 0: all nodes
};
/// The NMT command `command` to node `node_id` (0: all nodes).
CanFrame EncodeNmt(NmtCommand command, int node_id);
/// An NMT frame (id 0x000, 2 data bytes, a known command, node 0..127), else nothing with the
/// reason in `error`.
std::optional<NmtMessage> DecodeNmt(const CanFrame& frame, std::string* error = nullptr);

// ---------------------------------------------------------------------------------------- SYNC
/// A SYNC frame; with a counter (1..240) it carries one data byte.
CanFrame EncodeSync(std::optional<std::uint8_t> counter = std::nullopt, std::uint32_t cob_id = kSyncCobId);

/// The SYNC seen in a frame: nothing if `frame` is not a SYNC (other id, RTR, error frame or more
/// than one data byte), else the counter (empty for a 0-byte SYNC).
struct SyncInfo {
  std::optional<std::uint8_t> counter;
};
std::optional<SyncInfo> DecodeSync(const CanFrame& frame, std::uint32_t cob_id = kSyncCobId);

/// The counter after `counter` for a producer counting 1..max_counter: max_counter wraps to 1.
std::uint8_t NextSyncCounter(std::uint8_t counter, std::uint8_t max_counter);

/// SYNC frames missing between two received counters (0 when `current` follows `previous`).
int MissedSyncs(std::uint8_t previous, std::uint8_t current, std::uint8_t max_counter);

// ----------------------------------------------------------------------------- heartbeat, EMCY
struct Heartbeat {
  int node_id = 0;
  std::uint8_t state = 0;  ///< NmtState value
};
/// A heartbeat (0x701..0x77F, exactly 1 data byte), else nothing.
std::optional<Heartbeat> DecodeHeartbeat(const CanFrame& frame);
CanFrame EncodeHeartbeat(int node_id, NmtState state);

struct Emergency {
  int node_id = 0;
  std::uint16_t error_code = 0;     ///< CiA 301 error code, 0x0000 = error reset
  std::uint8_t error_register = 0;  ///< object 0x1001
  std::array<std::uint8_t, 5> manufacturer{};
};
/// An EMCY frame (0x081..0x0FF, 8 data bytes), else nothing. A shorter frame with an EMCY id is
/// not an EMCY: the caller counts it as malformed (IsEmergencyId tells).
std::optional<Emergency> DecodeEmergency(const CanFrame& frame);
bool IsEmergencyId(const CanFrame& frame);
CanFrame EncodeEmergency(const Emergency& emcy);
/// "0x8130 (monitoring: communication: heartbeat/guarding), register 0x11" style text.
std::string DescribeEmergency(const Emergency& emcy);

// ------------------------------------------------------------------------------ PDO fields
/// Where a value sits in a frame.
struct FieldLayout {
  std::uint32_t can_id = 0;  ///< identifier with flags: kEffFlag for 29-bit ids
  int offset_byte = 0;       ///< first byte of the value, 0..7
  int width_bytes = 4;       ///< 1..8
  bool is_signed = false;    ///< two's complement
  bool big_endian = false;   ///< CANopen is little endian
};

/// The TPDO number (1..4) whose predefined COB-ID (CiA 301 predefined connection set: 0x180,
/// 0x280, 0x380, 0x480 + node id) is `cob_id`, or 0.
int PredefinedTpdo(std::uint32_t cob_id, int node_id);

/// Throws sph::Error naming `what` when offset/width do not fit in 8 bytes.
void ValidateLayout(const FieldLayout& layout, const std::string& what);

/// The raw value of `layout` in `frame`, sign-extended when is_signed; nothing when the frame is
/// shorter than offset_byte + width_bytes. The frame's id is not checked here.
std::optional<std::int64_t> ExtractField(const CanFrame& frame, const FieldLayout& layout);

/// Writes `value` (its low width_bytes bytes) into `frame` at `layout`; frame.len grows to cover it.
void InsertField(CanFrame& frame, const FieldLayout& layout, std::int64_t value);

// ----------------------------------------------------------------------- CiA 406 encoder
/// One rotary encoder (CiA 406 position value 0x6004 mapped into a TPDO).
///
///   counts = dir * (raw - zero_offset_counts)
///   single-turn: angle_deg = 360 * (counts mod counts_per_rev) / counts_per_rev     in [0, 360)
///   multi-turn:  counts is taken modulo 2^(8 * width_bytes) as a signed number (so a counter that
///                wraps at its full range stays continuous), angle_deg = 360 * counts / counts_per_rev
struct EncoderConfig {
  int node_id = 1;  ///< for heartbeat and EMCY; 0 = not a CANopen node
  FieldLayout field{0x181, 0, 4, false, false};
  std::uint64_t counts_per_rev = 1U << 24;  ///< steps per revolution
  int direction = 1;                        ///< +1 or -1
  std::int64_t zero_offset_counts = 0;      ///< raw value at angle 0
  bool multi_turn = false;
  int tpdo = 0;  ///< the TPDO's number (objects 1800h/1A00h + tpdo - 1); 0: PredefinedTpdo() or 1
};

enum class DecodeStatus {
  kOk,
  kShort,        ///< the frame is too short for the field (malformed)
  kOutOfRange,   ///< single-turn raw value >= counts_per_rev; probe over or under range
  kDeviceError,  ///< the probe reports an error code or error status
};
const char* ToString(DecodeStatus status);

struct DecodedValue {
  DecodeStatus status = DecodeStatus::kOk;
  double value = 0.0;    ///< angle [deg] or probe reading [mm]; meaningful when kOk
  std::int64_t raw = 0;  ///< the raw field (0 when kShort)
};

/// Throws sph::Error (naming `what`) on a bad layout, counts_per_rev 0, direction not +-1.
void ValidateEncoder(const EncoderConfig& config, const std::string& what);
/// See EncoderConfig for the equations. The frame id is not checked.
DecodedValue DecodePosition(const EncoderConfig& config, const CanFrame& frame);
/// The raw position value an encoder sends at `angle_deg` (rounded to the nearest count); the
/// inverse of DecodePosition for the simulator and the tests.
std::int64_t EncodePositionRaw(const EncoderConfig& config, double angle_deg);

// --------------------------------------------------------------------------------- probe
/// A displacement probe: a CANopen TPDO (default) or any raw frame layout.
///
///   r_mm = offset_mm + scale_mm_per_count * raw
///
/// Flags, checked in this order: status byte (if status_offset_byte >= 0) with
/// (status & status_error_mask) != 0 -> kDeviceError; raw in error_raw -> kDeviceError;
/// raw == over_range_raw or raw == under_range_raw -> kOutOfRange.
struct ProbeConfig {
  int node_id = 3;  ///< for heartbeat and EMCY; 0 = sensor with its own frames, no CANopen node
  FieldLayout field{0x183, 0, 4, true, false};
  double scale_mm_per_count = 1e-6;  ///< 1 nm per count
  double offset_mm = 0.0;
  std::optional<std::int64_t> over_range_raw = 0x7FFFFFFF;
  std::optional<std::int64_t> under_range_raw = -0x7FFFFFFF - 1;
  std::vector<std::int64_t> error_raw;  ///< further raw values that mean "no valid reading"
  int status_offset_byte = -1;          ///< a status byte in the frame, -1 = none
  std::uint8_t status_error_mask = 0xFF;
  int tpdo = 0;  ///< as EncoderConfig::tpdo
  /// The field holds an IEEE 754 single (REAL32, 4 bytes, not signed as an integer): the value
  /// is offset_mm + scale_mm_per_count * the number; NaN is a device error, an infinity out of
  /// range; the raw range and error codes do not apply.
  bool real32 = false;
};

/// A probe value's CANopen data type (CiA 301): its field's width and signedness, or REAL32.
struct ProbeDataType {
  const char* name;  ///< "integer8", ..., "real32"
  int width_bytes;
  bool is_signed;
  bool real32;
};
/// The data types a probe's value may have: INTEGER8/16/32, UNSIGNED8/16/32, REAL32.
const std::vector<ProbeDataType>& ProbeDataTypes();
/// The data type named `name` (as ProbeDataTypes() names them); null for another name.
const ProbeDataType* FindProbeDataType(const std::string& name);

/// The TPDO number a device's `tpdo` setting means: itself, else the predefined one of its
/// COB-ID and node, else 1.
int TpdoNumber(int tpdo, std::uint32_t cob_id, int node_id);

void ValidateProbe(const ProbeConfig& config, const std::string& what);
DecodedValue DecodeProbe(const ProbeConfig& config, const CanFrame& frame);
/// The raw value for `r_mm` (rounded), clamped into the field so that it never equals a flag value.
std::int64_t EncodeProbeRaw(const ProbeConfig& config, double r_mm);

}  // namespace sph::can

#endif  // SPH_CAN_CANOPEN_HPP_
