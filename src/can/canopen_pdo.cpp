// PDO fields, CiA 406 position values and the probe value.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "sph/can/canopen.hpp"
#include "sph/core/error.hpp"

namespace sph::can {
namespace {

// Smallest and largest raw value a field can hold.
std::int64_t FieldMin(const FieldLayout& l) {
  if (!l.is_signed) return 0;
  return l.width_bytes >= 8 ? std::numeric_limits<std::int64_t>::min() : -(std::int64_t{1} << (8 * l.width_bytes - 1));
}
std::int64_t FieldMax(const FieldLayout& l) {
  if (l.width_bytes >= 8) return std::numeric_limits<std::int64_t>::max();
  return l.is_signed ? (std::int64_t{1} << (8 * l.width_bytes - 1)) - 1 : (std::int64_t{1} << (8 * l.width_bytes)) - 1;
}

// x mod m in [0, m) for m > 0, without overflow for any m.
std::int64_t PositiveMod(std::int64_t x, std::int64_t m) {
  const std::int64_t r = x % m;
  return r < 0 ? r + m : r;
}

}  // namespace

const char* ToString(DecodeStatus status) {
  switch (status) {
    case DecodeStatus::kOk:
      return "ok";
    case DecodeStatus::kShort:
      return "frame too short";
    case DecodeStatus::kOutOfRange:
      return "out of range";
    case DecodeStatus::kDeviceError:
      return "device error";
  }
  return "?";
}

int PredefinedTpdo(std::uint32_t cob_id, int node_id) {
  for (int k = 1; k <= 4; ++k) {
    if (cob_id == 0x080U + 0x100U * static_cast<std::uint32_t>(k) + static_cast<std::uint32_t>(node_id)) return k;
  }
  return 0;
}

int TpdoNumber(int tpdo, std::uint32_t cob_id, int node_id) {
  if (tpdo > 0) return tpdo;
  const int k = node_id == 0 ? 0 : PredefinedTpdo(cob_id, node_id);
  return k == 0 ? 1 : k;
}

void ValidateLayout(const FieldLayout& l, const std::string& what) {
  if (l.width_bytes < 1 || l.width_bytes > 8) {
    throw Error(what + ": width must be 1..8 bytes, got " + std::to_string(l.width_bytes));
  }
  if (l.offset_byte < 0 || l.offset_byte + l.width_bytes > kMaxDataBytes) {
    throw Error(what + ": a " + std::to_string(l.width_bytes) + "-byte value at byte " + std::to_string(l.offset_byte) +
                " does not fit in 8 data bytes");
  }
  const std::uint32_t id = l.can_id & ~kEffFlag;
  if ((l.can_id & (kRtrFlag | kErrFlag)) != 0 || id > ((l.can_id & kEffFlag) ? kEffMask : kSffMask)) {
    throw Error(what + ": invalid CAN id 0x" + [&] {
      char b[16];
      std::snprintf(b, sizeof b, "%X", l.can_id);
      return std::string(b);
    }());
  }
}

std::optional<std::int64_t> ExtractField(const CanFrame& frame, const FieldLayout& l) {
  if (l.offset_byte < 0 || l.width_bytes < 1 || l.width_bytes > 8 || frame.len < l.offset_byte + l.width_bytes) {
    return std::nullopt;
  }
  std::uint64_t v = 0;
  for (int i = 0; i < l.width_bytes; ++i) {
    const int byte =
        l.big_endian ? l.offset_byte + i : l.offset_byte + l.width_bytes - 1 - i;  // most significant first
    v = (v << 8) | frame.data[static_cast<std::size_t>(byte)];
  }
  const int bits = 8 * l.width_bytes;
  if (l.is_signed && bits < 64 && (v >> (bits - 1)) != 0) v |= ~std::uint64_t{0} << bits;  // sign-extend
  return static_cast<std::int64_t>(v);
}

void InsertField(CanFrame& frame, const FieldLayout& l, std::int64_t value) {
  auto v = static_cast<std::uint64_t>(value);
  for (int i = 0; i < l.width_bytes; ++i) {  // least significant first
    const int byte = l.big_endian ? l.offset_byte + l.width_bytes - 1 - i : l.offset_byte + i;
    frame.data[static_cast<std::size_t>(byte)] = static_cast<std::uint8_t>(v & 0xFF);
    v >>= 8;
  }
  frame.len = static_cast<std::uint8_t>(std::max<int>(frame.len, l.offset_byte + l.width_bytes));
}

void ValidateEncoder(const EncoderConfig& c, const std::string& what) {
  ValidateLayout(c.field, what);
  if (c.counts_per_rev == 0 ||
      c.counts_per_rev > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
    throw Error(what + ": counts per revolution must be 1..9223372036854775807, got " +
                std::to_string(c.counts_per_rev));
  }
  if (c.direction != 1 && c.direction != -1) throw Error(what + ": direction must be 1 or -1");
  if (c.node_id < 0 || c.node_id > 127) throw Error(what + ": node id must be 0..127");
  if (c.tpdo < 0 || c.tpdo > 512) throw Error(what + ": TPDO number must be 1..512 (0: from the COB-ID)");
}

DecodedValue DecodePosition(const EncoderConfig& c, const CanFrame& frame) {
  DecodedValue out;
  const auto raw = ExtractField(frame, c.field);
  if (!raw) {
    out.status = DecodeStatus::kShort;
    return out;
  }
  out.raw = *raw;
  const auto cpr = static_cast<std::int64_t>(c.counts_per_rev);
  if (!c.multi_turn) {
    if (*raw < 0 || *raw >= cpr) {
      out.status = DecodeStatus::kOutOfRange;
      return out;
    }
    const std::int64_t counts = PositiveMod(c.direction * (*raw - PositiveMod(c.zero_offset_counts, cpr)), cpr);
    out.value = 360.0 * static_cast<double>(counts) / static_cast<double>(cpr);
    return out;
  }
  // Multi-turn: the difference is taken on the field's own circle of 2^bits counts.
  const int bits = 8 * c.field.width_bytes;
  auto diff = static_cast<std::uint64_t>(*raw) - static_cast<std::uint64_t>(c.zero_offset_counts);
  if (bits < 64) {
    diff &= (std::uint64_t{1} << bits) - 1;
    if ((diff >> (bits - 1)) != 0) diff |= ~std::uint64_t{0} << bits;
  }
  if (c.direction < 0) diff = ~diff + 1;  // negated on the same circle: -(-2^63) stays -2^63
  const auto counts = static_cast<std::int64_t>(diff);
  out.value = 360.0 * static_cast<double>(counts) / static_cast<double>(cpr);
  return out;
}

std::int64_t EncodePositionRaw(const EncoderConfig& c, double angle_deg) {
  const auto cpr = static_cast<std::int64_t>(c.counts_per_rev);
  const auto counts = static_cast<std::int64_t>(std::llround(angle_deg / 360.0 * static_cast<double>(cpr)));
  // On the circle of 2^64 counts, as the encoder's counter wraps.
  const auto turn = static_cast<std::uint64_t>(counts);
  const auto raw = static_cast<std::int64_t>(static_cast<std::uint64_t>(c.zero_offset_counts) +
                                             (c.direction < 0 ? ~turn + 1 : turn));
  if (!c.multi_turn) return PositiveMod(raw, cpr);
  const int bits = 8 * c.field.width_bytes;
  if (bits >= 64) return raw;
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(raw) & ((std::uint64_t{1} << bits) - 1));
}

const std::vector<ProbeDataType>& ProbeDataTypes() {
  static const std::vector<ProbeDataType> types{{"integer8", 1, true, false},    {"integer16", 2, true, false},
                                                {"integer32", 4, true, false},   {"unsigned8", 1, false, false},
                                                {"unsigned16", 2, false, false}, {"unsigned32", 4, false, false},
                                                {"real32", 4, false, true}};
  return types;
}

const ProbeDataType* FindProbeDataType(const std::string& name) {
  for (const ProbeDataType& t : ProbeDataTypes()) {
    if (name == t.name) return &t;
  }
  return nullptr;
}

void ValidateProbe(const ProbeConfig& c, const std::string& what) {
  ValidateLayout(c.field, what);
  if (c.real32 && (c.field.width_bytes != 4 || c.field.is_signed)) {
    throw Error(what + ": a REAL32 value is 4 bytes, not read as a signed integer");
  }
  if (!(c.scale_mm_per_count != 0.0) || !std::isfinite(c.scale_mm_per_count)) {
    throw Error(what + ": the scale must be a non-zero number");
  }
  if (!std::isfinite(c.offset_mm)) throw Error(what + ": the offset must be finite");
  if (c.status_offset_byte >= kMaxDataBytes) throw Error(what + ": the status byte must be 0..7 (or -1 for none)");
  if (c.node_id < 0 || c.node_id > 127) throw Error(what + ": node id must be 0..127");
  if (c.tpdo < 0 || c.tpdo > 512) throw Error(what + ": TPDO number must be 1..512 (0: from the COB-ID)");
}

DecodedValue DecodeProbe(const ProbeConfig& c, const CanFrame& frame) {
  DecodedValue out;
  const auto raw = ExtractField(frame, c.field);
  if (!raw || (c.status_offset_byte >= 0 && frame.len <= c.status_offset_byte)) {
    out.status = DecodeStatus::kShort;
    return out;
  }
  out.raw = *raw;
  if (c.status_offset_byte >= 0 &&
      (frame.data[static_cast<std::size_t>(c.status_offset_byte)] & c.status_error_mask) != 0) {
    out.status = DecodeStatus::kDeviceError;
    return out;
  }
  if (c.real32) {
    const auto bits = static_cast<std::uint32_t>(*raw);
    float number = 0.0F;
    std::memcpy(&number, &bits, sizeof number);
    if (std::isnan(number)) {
      out.status = DecodeStatus::kDeviceError;
    } else if (std::isinf(number)) {
      out.status = DecodeStatus::kOutOfRange;
    } else {
      out.value = c.offset_mm + c.scale_mm_per_count * static_cast<double>(number);
    }
    return out;
  }
  if (std::find(c.error_raw.begin(), c.error_raw.end(), *raw) != c.error_raw.end()) {
    out.status = DecodeStatus::kDeviceError;
    return out;
  }
  if ((c.over_range_raw && *raw == *c.over_range_raw) || (c.under_range_raw && *raw == *c.under_range_raw)) {
    out.status = DecodeStatus::kOutOfRange;
    return out;
  }
  out.value = c.offset_mm + c.scale_mm_per_count * static_cast<double>(*raw);
  return out;
}

std::int64_t EncodeProbeRaw(const ProbeConfig& c, double r_mm) {
  if (c.real32) {  // the nearest single; its bits
    const auto number = static_cast<float>((r_mm - c.offset_mm) / c.scale_mm_per_count);
    std::uint32_t bits = 0;
    std::memcpy(&bits, &number, sizeof bits);
    return static_cast<std::int64_t>(bits);
  }
  std::int64_t lo = FieldMin(c.field), hi = FieldMax(c.field);
  if (c.under_range_raw && *c.under_range_raw == lo) ++lo;
  if (c.over_range_raw && *c.over_range_raw == hi) --hi;
  const double counts = std::round((r_mm - c.offset_mm) / c.scale_mm_per_count);
  if (!(counts > static_cast<double>(lo))) return lo;
  if (!(counts < static_cast<double>(hi))) return hi;
  return static_cast<std::int64_t>(counts);
}

}  // namespace sph::can
