#include "can_options.hpp"

#include <string>

#include <CLI/CLI.hpp>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

namespace r = can::ranges;

void AddEncoder(CLI::App& app, const std::string& name, can::EncoderOptions& e) {
  const std::string g = "Devices";
  const std::string axis = name == "theta" ? "Theta" : "Phi";
  app.add_option("--" + name + "-node", e.node, axis + " encoder: CANopen node id (NMT, SDO, heartbeat, EMCY); 0: none")
      ->check(IntegerIn(r::kNodeId))
      ->group(g);
  app.add_option("--" + name + "-cob-id", e.cob_id, axis + " encoder: TPDO COB-ID carrying the position (0x6004)")
      ->check(IntegerIn(r::kCobId))
      ->group(g);
  app.add_option("--" + name + "-offset-byte", e.offset_byte, axis + " encoder: first byte of the position in the PDO")
      ->check(IntegerIn(r::kOffsetByte))
      ->group(g);
  app.add_option("--" + name + "-width-bytes", e.width_bytes, axis + " encoder: bytes of the position value")
      ->check(IntegerIn(r::kWidthBytes))
      ->group(g);
  app.add_option("--" + name + "-counts-per-rev", e.counts_per_rev, axis + " encoder: counts per revolution")
      ->check(InRange(r::kCountsPerRev))
      ->group(g);
  app.add_option("--" + name + "-direction", e.direction, axis + " encoder: counting direction, 1 or -1")
      ->check(CLI::IsMember({1, -1}))
      ->group(g);
  app.add_option("--" + name + "-zero-counts", e.zero_counts, axis + " encoder: raw value at angle 0 [counts]")
      ->group(g);
  app.add_flag("--" + name + "-multi-turn", e.multi_turn,
               axis + " encoder: multi-turn (angles beyond 360 deg) instead of single-turn [0, 360)")
      ->group(g);
  app.add_option("--" + name + "-tpdo", e.tpdo,
                 axis +
                     " encoder: number of the TPDO carrying the position (objects 1800h/1A00h + n - 1); 0: from "
                     "the COB-ID (TPDO1..4 of the predefined connection set), else 1")
      ->check(IntegerIn(r::kTpdo))
      ->group(g);
  app.add_option("--" + name + "-sync-counter-byte", e.sync_counter_byte,
                 axis + " encoder: PDO byte holding the counter of the SYNC it answers (the device maps it); -1: none")
      ->check(IntegerIn(r::kOptionalByte))
      ->group(g);
}

// The probe's --probe-* options.
void AddProbe(CLI::App& app, can::DeviceOptions& o, const std::string& g) {
  app.add_option("--probe-node", o.probe_node,
                 "Probe: CANopen node id (NMT, SDO, heartbeat, EMCY); 0: a sensor with its own frames")
      ->check(IntegerIn(r::kNodeId))
      ->group(g);
  app.add_option(
         "--probe-cob-id", o.probe_cob_id,
         "Probe: CAN id of the frame carrying the reading (up to 0x7FF, or 0x1FFFFFFF with --probe-extended-id)")
      ->check(IntegerIn(r::kProbeCobId, true))
      ->group(g);
  app.add_flag("--probe-extended-id", o.probe_extended_id, "Probe: the id is a 29-bit (extended) id")->group(g);
  app.add_option("--probe-offset-byte", o.probe_offset_byte, "Probe: first byte of the reading")
      ->check(IntegerIn(r::kOffsetByte))
      ->group(g);
  app.add_option("--probe-width-bytes", o.probe_width_bytes, "Probe: bytes of the reading")
      ->check(IntegerIn(r::kWidthBytes))
      ->group(g);
  app.add_flag("--probe-unsigned", o.probe_unsigned, "Probe: the reading is unsigned (default: signed)")->group(g);
  app.add_flag("--probe-big-endian", o.probe_big_endian, "Probe: the reading is big endian (default: little)")
      ->group(g);
  app.add_option("--probe-data-type", o.probe_data_type,
                 "Probe: the reading's CANopen data type, integer8/16/32, unsigned8/16/32 or real32 (sets its width "
                 "and sign instead of --probe-width-bytes and --probe-unsigned; real32: an IEEE 754 single, times the "
                 "scale, NaN a device error, infinity out of range; empty: as --probe-width-bytes and --probe-unsigned say)")
      ->check(CLI::IsMember({"", "integer8", "integer16", "integer32", "unsigned8", "unsigned16", "unsigned32", "real32"}))
      ->group(g);
  auto* nm = app.add_option("--probe-scale-nm-per-count", o.probe_scale_nm_per_count,
                            "Probe: scale [nm per count], not 0 (negative: the probe counts the other way)")
                 ->check(InRange(r::kScaleNmPerCount))
                 ->group(g);
  app.add_option("--probe-scale-um-per-count", o.probe_scale_um_per_count,
                 "Probe: scale [um per count] (instead of nm)")
      ->check(InRange(r::kScaleUmPerCount))
      ->excludes(nm)
      ->group(g);
  app.add_option("--probe-value-offset-mm", o.probe_offset_mm, "Probe: r = value offset + scale * raw [mm]")
      ->check(InRange(r::kValueOffsetMm))
      ->group(g);
  app.add_option("--probe-over-range-raw", o.probe_over_range_raw, "Probe: raw value meaning 'over range'")->group(g);
  app.add_option("--probe-under-range-raw", o.probe_under_range_raw, "Probe: raw value meaning 'under range'")
      ->group(g);
  app.add_flag("--probe-no-range-codes", o.probe_no_range_codes, "Probe: no raw value means out of range")->group(g);
  app.add_option("--probe-error-raw", o.probe_error_raw, "Probe: a raw value meaning 'no valid reading' (repeatable)")
      ->group(g);
  app.add_option("--probe-status-byte", o.probe_status_byte, "Probe: byte with status bits; -1: none")
      ->check(IntegerIn(r::kOptionalByte))
      ->group(g);
  app.add_option("--probe-status-error-mask", o.probe_status_error_mask, "Probe: status bits that mean an error")
      ->check(IntegerIn(r::kStatusErrorMask))
      ->group(g);
  app.add_option("--probe-tpdo", o.probe_tpdo, "Probe: number of the TPDO carrying the reading; 0: from the COB-ID")
      ->check(IntegerIn(r::kTpdo))
      ->group(g);
  app.add_option("--probe-sync-counter-byte", o.probe_sync_counter_byte,
                 "Probe: PDO byte holding the counter of the SYNC it answers; -1: none")
      ->check(IntegerIn(r::kOptionalByte))
      ->group(g);
}

}  // namespace

CLI::Validator ZeroOrInRange(const ValidRange& range, const std::string& zero) {
  return CLI::Validator([range, zero](std::string& text) { return RefusalOf(text, 0.0, zero, range); },
                        "0 or " + range.Text());
}

CLI::Validator IntegerIn(const ValidRange& range, bool is_unsigned) {
  if (is_unsigned) return CLI::Range(static_cast<unsigned>(range.lo), static_cast<unsigned>(range.hi));
  return CLI::Range(static_cast<int>(range.lo), static_cast<int>(range.hi));
}

CLI::Validator InterfaceName() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (text.empty() || text.size() > 15) {
          return "an interface name has 1 to 15 characters, got " + std::to_string(text.size());
        }
        if (text == "." || text == ".." || text.find_first_of(" \t\n\r\v\f/:") != std::string::npos) {
          return "an interface name has no space, '/' or ':' and is not '.' or '..', got " + internal::Quoted(text);
        }
        return "";
      },
      "NAME");
}

void AddDeviceOptions(CLI::App& app, can::DeviceOptions& o, bool period_may_be_unknown) {
  const std::string g = "Devices";
  AddEncoder(app, "theta", o.theta);
  AddEncoder(app, "phi", o.phi);
  AddProbe(app, o, g);
  app.add_option("--sync-cob-id", o.sync_cob_id, "SYNC COB-ID")->check(IntegerIn(r::kCobId))->group(g);
  app.add_option("--sync-counter-max", o.sync_counter_max,
                 "SYNC counter overflow value (2..240; the SYNC carries a counter byte); 0: no counter")
      ->check(IntegerIn(r::kSyncCounterMax))
      ->group(g);
  if (period_may_be_unknown) {
    app.add_option("--sync-period-ms", o.sync_period_ms,
                   "SYNC period [ms]: produced at this period (default 1), or expected of the external producer "
                   "or in the replayed log (gap detection; 0 or not given there: as observed)")
        ->check(ZeroOrInRange(r::kSyncPeriodMs, "unknown"))
        ->group(g);
  } else {
    app.add_option("--sync-period-ms", o.sync_period_ms, "SYNC period [ms] (default 1)")
        ->check(InRange(r::kSyncPeriodMs))
        ->group(g);
  }
}

}  // namespace sph::apps
