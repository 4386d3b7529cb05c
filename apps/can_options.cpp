#include "can_options.hpp"

#include <map>
#include <sstream>

#include <CLI/CLI.hpp>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

constexpr ValidRange kCountsPerRev{1.0, 4294967295.0, "counts"};  // 6001h is UNSIGNED32
constexpr ValidRange kScaleNmPerCount{-1e9, 1e9, "nm"};
constexpr ValidRange kScaleUmPerCount{0.0, 1e6, "um", true};
constexpr ValidRange kValueOffsetMm{-1e4, 1e4, "mm"};

std::string Trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

// The option a config file's key sets in `app`, as CLI11 looks it up; null when none.
CLI::Option* ConfigOption(CLI::App& app, const std::string& key) {
  CLI::Option* op = app.get_option_no_throw("--" + key);
  if (op == nullptr && key.size() == 1) op = app.get_option_no_throw("-" + key);
  if (op == nullptr) op = app.get_option_no_throw(key);
  return op;
}

// CLI11's TOML reader, after the checks of UseStrictConfig.
class StrictConfig : public CLI::ConfigTOML {
 public:
  StrictConfig(CLI::App* app, std::string program, std::string* path_read, std::shared_ptr<CLI::App> also_known)
      : app_(app), program_(std::move(program)), path_read_(path_read), also_known_(std::move(also_known)) {}

  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override {
    const std::string path = app_->get_config_ptr()->as<std::string>();
    if (path_read_ != nullptr) *path_read_ = path;
    TextLines lines(input, path, "a configuration file");
    std::string text, line;
    std::map<const CLI::Option*, long> seen;
    bool in_array = false;  // a value "[a, b, ...]" continued on the next lines
    while (lines.Next(line)) {
      text += line + "\n";
      const std::string t = Trim(line);
      if (in_array) {
        in_array = t.empty() || t.back() != ']';
        continue;
      }
      if (t.empty() || t[0] == '#' || t[0] == ';') continue;
      if (t[0] == '[') {
        throw Error(lines.Where() + "a section " + internal::Quoted(t) + ": " + program_ +
                    " reads 'name = value' lines without sections");
      }
      const auto eq = t.find('=');
      std::string key = Trim(t.substr(0, eq == std::string::npos ? t.find('#') : eq));
      if (key.size() >= 2 && (key.front() == '"' || key.front() == '\'') && key.back() == key.front()) {
        key = key.substr(1, key.size() - 2);
      }
      if (eq != std::string::npos) {
        const std::string value = Trim(t.substr(eq + 1));
        in_array =
            value.size() > 1 && value[0] == '[' && value.substr(0, value.find('#')).find(']') == std::string::npos;
      }
      if (key.empty()) throw Error(lines.Where() + "expected 'name = value', got " + internal::Quoted(t));
      const CLI::Option* op = ConfigOption(*app_, key);
      if (op == nullptr) {
        if (also_known_ && ConfigOption(*also_known_, key) != nullptr) continue;  // the other program's
        throw Error(lines.Where() + "unknown option " + internal::Quoted(key) + ": not an option of " + program_ +
                    " (see --help; the names are the long options without their dashes)");
      }
      if (!op->get_configurable()) {
        throw Error(lines.Where() + internal::Quoted(key) + " cannot be set in a configuration file");
      }
      const auto [first, fresh] = seen.emplace(op, lines.line_no());
      if (!fresh) {
        throw Error(lines.Where() + internal::Quoted(key) + " is given twice (first at line " +
                    std::to_string(first->second) + "): give each option once");
      }
    }
    std::istringstream checked(text);
    return CLI::ConfigTOML::from_config(checked);
  }

 private:
  CLI::App* app_;
  std::string program_;
  std::string* path_read_;
  std::shared_ptr<CLI::App> also_known_;
};

void AddEncoder(CLI::App& app, const std::string& name, EncoderOptions& e) {
  const std::string g = "Devices";
  const std::string axis = name == "theta" ? "Theta" : "Phi";
  app.add_option("--" + name + "-node", e.node, axis + " encoder: CANopen node id (NMT, SDO, heartbeat, EMCY); 0: none")
      ->check(CLI::Range(0, 127))
      ->group(g);
  app.add_option("--" + name + "-cob-id", e.cob_id, axis + " encoder: TPDO COB-ID carrying the position (0x6004)")
      ->check(CLI::Range(1, 0x7FF))
      ->group(g);
  app.add_option("--" + name + "-offset-byte", e.offset_byte, axis + " encoder: first byte of the position in the PDO")
      ->check(CLI::Range(0, 7))
      ->group(g);
  app.add_option("--" + name + "-width-bytes", e.width_bytes, axis + " encoder: bytes of the position value")
      ->check(CLI::Range(1, 8))
      ->group(g);
  app.add_option("--" + name + "-counts-per-rev", e.counts_per_rev, axis + " encoder: counts per revolution")
      ->check(InRange(kCountsPerRev))
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

CLI::Validator ZeroOrInRange(const ValidRange& range, const std::string& zero) {
  return CLI::Validator(
      [range, zero](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end != text.c_str() && *end == '\0' && (v == 0.0 || range.Contains(v))) return "";
        return "must be 0 (" + zero + ") or " + range.Refusal(text).substr(std::string("must be ").size());
      },
      "0 or " + range.Text());
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

void UseStrictConfig(CLI::App& app, const std::string& program, std::string* path_read,
                     std::shared_ptr<CLI::App> also_known) {
  app.config_formatter(std::make_shared<StrictConfig>(&app, program, path_read, std::move(also_known)));
}

void AddDeviceOptions(CLI::App& app, DeviceOptions& o, bool period_may_be_unknown) {
  AddEncoder(app, "theta", o.theta);
  AddEncoder(app, "phi", o.phi);
  const std::string g = "Devices";
  app.add_option("--probe-node", o.probe_node,
                 "Probe: CANopen node id (NMT, SDO, heartbeat, EMCY); 0: a sensor with its own frames")
      ->check(CLI::Range(0, 127))
      ->group(g);
  app.add_option(
         "--probe-cob-id", o.probe_cob_id,
         "Probe: CAN id of the frame carrying the reading (up to 0x7FF, or 0x1FFFFFFF with --probe-extended-id)")
      ->check(CLI::Range(0U, 0x1FFFFFFFU))
      ->group(g);
  app.add_flag("--probe-extended-id", o.probe_extended_id, "Probe: the id is a 29-bit (extended) id")->group(g);
  app.add_option("--probe-offset-byte", o.probe_offset_byte, "Probe: first byte of the reading")
      ->check(CLI::Range(0, 7))
      ->group(g);
  app.add_option("--probe-width-bytes", o.probe_width_bytes, "Probe: bytes of the reading")
      ->check(CLI::Range(1, 8))
      ->group(g);
  app.add_flag("--probe-unsigned", o.probe_unsigned, "Probe: the reading is unsigned (default: signed)")->group(g);
  app.add_flag("--probe-big-endian", o.probe_big_endian, "Probe: the reading is big endian (default: little)")
      ->group(g);
  auto* nm = app.add_option("--probe-scale-nm-per-count", o.probe_scale_nm_per_count,
                            "Probe: scale [nm per count], not 0 (negative: the probe counts the other way)")
                 ->check(InRange(kScaleNmPerCount))
                 ->group(g);
  app.add_option("--probe-scale-um-per-count", o.probe_scale_um_per_count,
                 "Probe: scale [um per count] (instead of nm)")
      ->check(InRange(kScaleUmPerCount))
      ->excludes(nm)
      ->group(g);
  app.add_option("--probe-value-offset-mm", o.probe_offset_mm, "Probe: r = value offset + scale * raw [mm]")
      ->check(InRange(kValueOffsetMm))
      ->group(g);
  app.add_option("--probe-over-range-raw", o.probe_over_range_raw, "Probe: raw value meaning 'over range'")->group(g);
  app.add_option("--probe-under-range-raw", o.probe_under_range_raw, "Probe: raw value meaning 'under range'")
      ->group(g);
  app.add_flag("--probe-no-range-codes", o.probe_no_range_codes, "Probe: no raw value means out of range")->group(g);
  app.add_option("--probe-error-raw", o.probe_error_raw, "Probe: a raw value meaning 'no valid reading' (repeatable)")
      ->group(g);
  app.add_option("--probe-status-byte", o.probe_status_byte, "Probe: byte with status bits; -1: none")
      ->check(CLI::Range(-1, 7))
      ->group(g);
  app.add_option("--probe-status-error-mask", o.probe_status_error_mask, "Probe: status bits that mean an error")
      ->check(CLI::Range(1, 255))
      ->group(g);
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
      ->check(CLI::Range(0, 240))
      ->group(g);
  if (period_may_be_unknown) {
    app.add_option("--sync-period-ms", o.sync_period_ms,
                   "SYNC period [ms]: produced at this period (default 1), or expected of the external producer "
                   "or in the replayed log (gap detection; 0 or not given there: as observed)")
        ->check(ZeroOrInRange(ranges::kSyncPeriodMs, "unknown"))
        ->group(g);
  } else {
    app.add_option("--sync-period-ms", o.sync_period_ms, "SYNC period [ms] (default 1)")
        ->check(InRange(ranges::kSyncPeriodMs))
        ->group(g);
  }
}

void ApplyDeviceOptions(const DeviceOptions& o, can::PipelineConfig& c) {
  for (const auto& [e, name] : {std::pair<const EncoderOptions&, std::string>{o.theta, "theta"}, {o.phi, "phi"}}) {
    const int bits = 8 * e.width_bytes;
    if (bits < 64 && e.counts_per_rev > (std::uint64_t{1} << bits)) {
      int need = 1;
      while (need < 8 && e.counts_per_rev > (std::uint64_t{1} << (8 * need))) ++need;
      throw Error("--" + name + "-width-bytes " + std::to_string(e.width_bytes) + ": a position of " +
                  std::to_string(bits) + " bits cannot count the " + std::to_string(e.counts_per_rev) +
                  " steps of one revolution (--" + name + "-counts-per-rev); give at least " + std::to_string(need) +
                  " bytes");
    }
  }
  if (!o.probe_extended_id && o.probe_cob_id > can::kSffMask) {
    throw Error("--probe-cob-id " + internal::Format("0x%X", o.probe_cob_id) +
                ": an 11-bit id is at most 0x7FF (--probe-extended-id for a 29-bit id)");
  }
  if (o.probe_scale_um_per_count == 0.0 && o.probe_scale_nm_per_count == 0.0) {
    throw Error("--probe-scale-nm-per-count: must not be 0 nm");
  }
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
  c.sync_period_s = o.sync_period_ms.value_or(kDefaultSyncPeriodMs) * 1e-3;
  c.Validate();
}

}  // namespace sph::apps
