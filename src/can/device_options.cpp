#include "sph/can/device_options.hpp"

#include <string>
#include <utility>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

void CheckEncoder(const EncoderOptions& e, const std::string& name) {
  const std::string o = "--" + name;
  CheckedValue(e.node, ranges::kNodeId, o + "-node");
  CheckedValue(e.cob_id, ranges::kCobId, o + "-cob-id");
  CheckedValue(e.offset_byte, ranges::kOffsetByte, o + "-offset-byte");
  CheckedValue(e.width_bytes, ranges::kWidthBytes, o + "-width-bytes");
  CheckedValue(e.counts_per_rev, ranges::kCountsPerRev, o + "-counts-per-rev");
  if (e.direction != 1 && e.direction != -1) {
    throw Error(o + "-direction: must be 1 or -1, got " + std::to_string(e.direction));
  }
  CheckedValue(e.tpdo, ranges::kTpdo, o + "-tpdo");
  CheckedValue(e.sync_counter_byte, ranges::kOptionalByte, o + "-sync-counter-byte");
  const int bits = 8 * e.width_bytes;
  if (bits < 64 && e.counts_per_rev > (std::uint64_t{1} << bits)) {
    int need = 1;
    while (need < 8 && e.counts_per_rev > (std::uint64_t{1} << (8 * need))) ++need;
    throw Error(o + "-width-bytes " + std::to_string(e.width_bytes) + ": a position of " + std::to_string(bits) +
                " bits cannot count the " + std::to_string(e.counts_per_rev) + " steps of one revolution (" + o +
                "-counts-per-rev); give at least " + std::to_string(need) + " bytes");
  }
}

void CheckProbe(const DeviceOptions& o) {
  CheckedValue(o.probe_node, ranges::kNodeId, "--probe-node");
  CheckedValue(o.probe_cob_id, ranges::kProbeCobId, "--probe-cob-id");
  CheckedValue(o.probe_offset_byte, ranges::kOffsetByte, "--probe-offset-byte");
  CheckedValue(o.probe_width_bytes, ranges::kWidthBytes, "--probe-width-bytes");
  CheckedValue(o.probe_scale_nm_per_count, ranges::kScaleNmPerCount, "--probe-scale-nm-per-count");
  if (o.probe_scale_um_per_count != 0.0) {
    CheckedValue(o.probe_scale_um_per_count, ranges::kScaleUmPerCount, "--probe-scale-um-per-count");
  }
  CheckedValue(o.probe_offset_mm, ranges::kValueOffsetMm, "--probe-value-offset-mm");
  CheckedValue(o.probe_status_byte, ranges::kOptionalByte, "--probe-status-byte");
  CheckedValue(o.probe_status_error_mask, ranges::kStatusErrorMask, "--probe-status-error-mask");
  CheckedValue(o.probe_tpdo, ranges::kTpdo, "--probe-tpdo");
  CheckedValue(o.probe_sync_counter_byte, ranges::kOptionalByte, "--probe-sync-counter-byte");
  if (!o.probe_extended_id && o.probe_cob_id > kSffMask) {
    throw Error("--probe-cob-id " + internal::Format("0x%X", o.probe_cob_id) +
                ": an 11-bit id is at most 0x7FF (--probe-extended-id for a 29-bit id)");
  }
  if (!o.probe_data_type.empty() && FindProbeDataType(o.probe_data_type) == nullptr) {
    std::string names;
    for (const ProbeDataType& t : ProbeDataTypes()) names += (names.empty() ? "" : ", ") + std::string(t.name);
    throw Error("--probe-data-type " + internal::Quoted(o.probe_data_type) + ": not a data type of " + names);
  }
  if (o.probe_scale_um_per_count == 0.0 && o.probe_scale_nm_per_count == 0.0) {
    throw Error("--probe-scale-nm-per-count: must not be 0 nm");
  }
}

void CheckSync(const DeviceOptions& o) {
  CheckedValue(o.sync_cob_id, ranges::kCobId, "--sync-cob-id");
  CheckedValue(o.sync_counter_max, ranges::kSyncCounterMax, "--sync-counter-max");
  if (o.sync_counter_max == 1) throw Error("--sync-counter-max: 1 is not allowed (0 or 2..240)");
  if (o.sync_period_ms) CheckedValueOr(*o.sync_period_ms, 0.0, "unknown", ranges::kSyncPeriodMs, "--sync-period-ms");
}

EncoderConfig ToEncoder(const EncoderOptions& e) {
  EncoderConfig c;
  c.node_id = e.node;
  c.field = {e.cob_id, e.offset_byte, e.width_bytes, false, false};
  c.counts_per_rev = e.counts_per_rev;
  c.direction = e.direction;
  c.zero_offset_counts = e.zero_counts;
  c.multi_turn = e.multi_turn;
  c.tpdo = e.tpdo;
  return c;
}

}  // namespace

PipelineConfig DevicesConfig(const DeviceOptions& o) {
  CheckEncoder(o.theta, "theta");
  CheckEncoder(o.phi, "phi");
  CheckProbe(o);
  CheckSync(o);
  PipelineConfig c;
  c.theta = ToEncoder(o.theta);
  c.phi = ToEncoder(o.phi);
  c.probe.node_id = o.probe_node;
  c.probe.field = {o.probe_cob_id | (o.probe_extended_id ? kEffFlag : 0U), o.probe_offset_byte, o.probe_width_bytes,
                   !o.probe_unsigned, o.probe_big_endian};
  c.probe.scale_mm_per_count =
      o.probe_scale_um_per_count > 0.0 ? o.probe_scale_um_per_count * 1e-3 : o.probe_scale_nm_per_count * 1e-6;
  c.probe.offset_mm = o.probe_offset_mm;
  if (o.probe_no_range_codes) {
    c.probe.over_range_raw.reset();
    c.probe.under_range_raw.reset();
  } else {
    c.probe.over_range_raw = o.probe_over_range_raw;
    c.probe.under_range_raw = o.probe_under_range_raw;
  }
  c.probe.error_raw = o.probe_error_raw;
  if (const ProbeDataType* type = FindProbeDataType(o.probe_data_type)) {
    c.probe.field.width_bytes = type->width_bytes;
    c.probe.field.is_signed = type->is_signed;
    c.probe.real32 = type->real32;
    if (type->real32) {  // infinities and NaN say it; no raw codes
      c.probe.over_range_raw.reset();
      c.probe.under_range_raw.reset();
    }
  }
  c.probe.status_offset_byte = o.probe_status_byte;
  c.probe.status_error_mask = static_cast<std::uint8_t>(o.probe_status_error_mask);
  c.probe.tpdo = o.probe_tpdo;
  c.sync_counter_byte = {o.theta.sync_counter_byte, o.phi.sync_counter_byte, o.probe_sync_counter_byte};
  c.sync_cob_id = o.sync_cob_id;
  c.sync_counter_max = static_cast<std::uint8_t>(o.sync_counter_max);
  c.sync_period_s = o.sync_period_ms.value_or(kDefaultSyncPeriodMs) * 1e-3;
  c.Validate();
  return c;
}

}  // namespace sph::can
