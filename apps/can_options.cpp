#include "can_options.hpp"

#include "app_common.hpp"
#include "sph/core/error.hpp"

namespace sph::apps {
namespace {

void AddEncoder(CLI::App& app, const std::string& name, EncoderOptions& e) {
  const std::string g = "Devices";
  const std::string axis = name == "theta" ? "Theta" : "Phi";
  app.add_option("--" + name + "-node", e.node, axis + " encoder: CANopen node id (NMT, SDO, heartbeat, EMCY); 0: none")
      ->check(CLI::Range(0, 127))
      ->group(g);
  app.add_option("--" + name + "-cob-id", e.cob_id, axis + " encoder: TPDO COB-ID carrying the position (0x6004)")
      ->check(CLI::Range(1, 0x7FF))->group(g);
  app.add_option("--" + name + "-offset-byte", e.offset_byte, axis + " encoder: first byte of the position in the PDO")
      ->check(CLI::Range(0, 7))->group(g);
  app.add_option("--" + name + "-width-bytes", e.width_bytes, axis + " encoder: bytes of the position value")
      ->check(CLI::Range(1, 8))->group(g);
  app.add_option("--" + name + "-counts-per-rev", e.counts_per_rev, axis + " encoder: counts per revolution")
      ->check(Positive())->group(g);
  app.add_option("--" + name + "-direction", e.direction, axis + " encoder: counting direction, 1 or -1")
      ->check(CLI::IsMember({1, -1}))->group(g);
  app.add_option("--" + name + "-zero-counts", e.zero_counts, axis + " encoder: raw value at angle 0 [counts]")->group(g);
  app.add_flag("--" + name + "-multi-turn", e.multi_turn,
               axis + " encoder: multi-turn (angles beyond 360 deg) instead of single-turn [0, 360)")->group(g);
  app.add_option("--" + name + "-tpdo", e.tpdo,
                 axis +
                     " encoder: number of the TPDO carrying the position (objects 1800h/1A00h + n - 1); 0: from "
                     "the COB-ID (TPDO1..4 of the predefined connection set), else 1")
      ->check(CLI::Range(0, 512))
      ->group(g);
  app.add_option("--" + name + "-sync-counter-byte", e.sync_counter_byte,
                 axis + " encoder: PDO byte holding the counter of the SYNC it answers (the device maps it); -1: none")
      ->check(CLI::Range(-1, 7))
      ->group(g);
}

can::EncoderConfig ToEncoder(const EncoderOptions& e) {
  can::EncoderConfig c;
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

void AddDeviceOptions(CLI::App& app, DeviceOptions& o) {
  AddEncoder(app, "theta", o.theta);
  AddEncoder(app, "phi", o.phi);
  const std::string g = "Devices";
  app.add_option("--probe-node", o.probe_node,
                 "Probe: CANopen node id (NMT, SDO, heartbeat, EMCY); 0: a sensor with its own frames")
      ->check(CLI::Range(0, 127))
      ->group(g);
  app.add_option("--probe-cob-id", o.probe_cob_id, "Probe: CAN id of the frame carrying the reading")->group(g);
  app.add_flag("--probe-extended-id", o.probe_extended_id, "Probe: the id is a 29-bit (extended) id")->group(g);
  app.add_option("--probe-offset-byte", o.probe_offset_byte, "Probe: first byte of the reading")
      ->check(CLI::Range(0, 7))->group(g);
  app.add_option("--probe-width-bytes", o.probe_width_bytes, "Probe: bytes of the reading")
      ->check(CLI::Range(1, 8))->group(g);
  app.add_flag("--probe-unsigned", o.probe_unsigned, "Probe: the reading is unsigned (default: signed)")->group(g);
  app.add_flag("--probe-big-endian", o.probe_big_endian, "Probe: the reading is big endian (default: little)")
      ->group(g);
  auto* nm = app.add_option("--probe-scale-nm-per-count", o.probe_scale_nm_per_count, "Probe: scale [nm per count]")
                 ->group(g);
  app.add_option("--probe-scale-um-per-count", o.probe_scale_um_per_count, "Probe: scale [um per count] (instead of nm)")
      ->check(Positive())->excludes(nm)->group(g);
  app.add_option("--probe-value-offset-mm", o.probe_offset_mm, "Probe: r = value offset + scale * raw [mm]")->group(g);
  app.add_option("--probe-over-range-raw", o.probe_over_range_raw, "Probe: raw value meaning 'over range'")->group(g);
  app.add_option("--probe-under-range-raw", o.probe_under_range_raw, "Probe: raw value meaning 'under range'")->group(g);
  app.add_flag("--probe-no-range-codes", o.probe_no_range_codes, "Probe: no raw value means out of range")->group(g);
  app.add_option("--probe-error-raw", o.probe_error_raw, "Probe: a raw value meaning 'no valid reading' (repeatable)")
      ->group(g);
  app.add_option("--probe-status-byte", o.probe_status_byte, "Probe: byte with status bits; -1: none")
      ->check(CLI::Range(-1, 7))->group(g);
  app.add_option("--probe-status-error-mask", o.probe_status_error_mask, "Probe: status bits that mean an error")
      ->check(CLI::Range(1, 255))->group(g);
  app.add_option("--probe-tpdo", o.probe_tpdo, "Probe: number of the TPDO carrying the reading; 0: from the COB-ID")
      ->check(CLI::Range(0, 512))
      ->group(g);
  app.add_option("--probe-sync-counter-byte", o.probe_sync_counter_byte,
                 "Probe: PDO byte holding the counter of the SYNC it answers; -1: none")
      ->check(CLI::Range(-1, 7))
      ->group(g);
  app.add_option("--sync-cob-id", o.sync_cob_id, "SYNC COB-ID")->check(CLI::Range(1, 0x7FF))->group(g);
  app.add_option("--sync-counter-max", o.sync_counter_max,
                 "SYNC counter overflow value (2..240; the SYNC carries a counter byte); 0: no counter")
      ->check(CLI::Range(0, 240))->group(g);
  app.add_option("--sync-period-ms", o.sync_period_ms,
                 "SYNC period [ms]: produced at this period, or expected from the external producer (gap detection; "
                 "0: unknown)")
      ->check(NonNegative())->group(g);
}

void ApplyDeviceOptions(const DeviceOptions& o, can::PipelineConfig& c) {
  c.theta = ToEncoder(o.theta);
  c.phi = ToEncoder(o.phi);
  c.probe.node_id = o.probe_node;
  c.probe.field = {o.probe_cob_id | (o.probe_extended_id ? can::kEffFlag : 0U), o.probe_offset_byte,
                   o.probe_width_bytes, !o.probe_unsigned, o.probe_big_endian};
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
  c.probe.status_offset_byte = o.probe_status_byte;
  c.probe.status_error_mask = static_cast<std::uint8_t>(o.probe_status_error_mask);
  c.probe.tpdo = o.probe_tpdo;
  c.sync_counter_byte = {o.theta.sync_counter_byte, o.phi.sync_counter_byte, o.probe_sync_counter_byte};
  c.sync_cob_id = o.sync_cob_id;
  if (o.sync_counter_max == 1) throw Error("--sync-counter-max: 1 is not allowed (0 or 2..240)");
  c.sync_counter_max = static_cast<std::uint8_t>(o.sync_counter_max);
  c.sync_period_s = o.sync_period_ms * 1e-3;
  c.Validate();
}

}  // namespace sph::apps
