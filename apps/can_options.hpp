// Device options shared by sph_acquired and sph_cansim: the same names configure the daemon and
// the simulated machine, so one config file serves both.
#ifndef SPH_APPS_CAN_OPTIONS_HPP_
#define SPH_APPS_CAN_OPTIONS_HPP_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "sph/can/pipeline.hpp"

namespace sph::apps {

struct EncoderOptions {
  int node = 1;
  std::uint32_t cob_id = 0x181;
  int offset_byte = 0;
  int width_bytes = 4;
  std::uint64_t counts_per_rev = 1U << 24;
  int direction = 1;
  std::int64_t zero_counts = 0;
  bool multi_turn = false;
  int tpdo = 0;                ///< 0: from the COB-ID (predefined connection set)
  int sync_counter_byte = -1;  ///< the PDO byte with the SYNC counter; -1: none
};

struct DeviceOptions {
  EncoderOptions theta{1, 0x181};
  EncoderOptions phi{2, 0x182};
  int probe_node = 3;
  std::uint32_t probe_cob_id = 0x183;
  bool probe_extended_id = false;
  int probe_offset_byte = 0;
  int probe_width_bytes = 4;
  bool probe_unsigned = false;
  bool probe_big_endian = false;
  double probe_scale_nm_per_count = 1.0;
  double probe_scale_um_per_count = 0.0;  ///< when set (> 0), replaces the nm scale
  double probe_offset_mm = 0.0;
  std::int64_t probe_over_range_raw = 0x7FFFFFFF;
  std::int64_t probe_under_range_raw = -0x7FFFFFFF - 1;
  bool probe_no_range_codes = false;
  std::vector<std::int64_t> probe_error_raw;
  int probe_status_byte = -1;
  int probe_status_error_mask = 0xFF;
  int probe_tpdo = 0;
  int probe_sync_counter_byte = -1;
  std::uint32_t sync_cob_id = 0x80;
  int sync_counter_max = 0;
  /// SYNC period [ms]; not given: kDefaultSyncPeriodMs where SYNC is produced, else (a daemon
  /// following a producer, a replay) as observed.
  std::optional<double> sync_period_ms;
};

/// The SYNC period where none is given [ms].
inline constexpr double kDefaultSyncPeriodMs = 1.0;

/// Adds the --theta-*, --phi-*, --probe-* and --sync-* options, in option group "Devices".
/// `period_may_be_unknown`: --sync-period-ms 0 means "not known" (a daemon following an
/// external SYNC producer); else the period must be given.
void AddDeviceOptions(CLI::App& app, DeviceOptions& options, bool period_may_be_unknown);

/// The pipeline's device part (encoders, probe, SYNC id, counter, period) from the options; a
/// period not given is kDefaultSyncPeriodMs. Throws sph::Error on an inconsistent set.
void ApplyDeviceOptions(const DeviceOptions& options, can::PipelineConfig& config);

/// Ranges of the CAN apps' options.
namespace ranges {
inline constexpr ValidRange kSyncPeriodMs{0.1, 60000.0, "ms"};
/// Times after the start of a simulation or acquisition, and durations: up to about three years.
inline constexpr ValidRange kRunTimeS{0.0, 1e8, "s"};
/// Times since the epoch that a frame time in ns (64 bits) can hold: up to the year 2261.
inline constexpr ValidRange kEpochTimeS{0.0, 9.2e9, "s", false, true};
}  // namespace ranges

/// A CLI11 check for a number that is 0 (which means `zero`, e.g. "none") or in `range`:
/// "--heartbeat-period-s: must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-300".
CLI::Validator ZeroOrInRange(const ValidRange& range, const std::string& zero);

/// A CLI11 check for a Linux network interface name: 1 to 15 characters, none of them a space,
/// '/' or ':' (the kernel's rule), and not "." or "..".
CLI::Validator InterfaceName();

/// Makes `app` read its --config file strictly, the way the apps read every text input: a line
/// that names no option of `program` (nor of `also_known`, whose options the file may hold for
/// the other program), an option given twice, a section header or binary data (a NUL byte) is
/// refused with "<file>:<line>: <problem>". The path of the file read is put in `*path_read`.
void UseStrictConfig(CLI::App& app, const std::string& program, std::string* path_read,
                     std::shared_ptr<CLI::App> also_known = nullptr);

}  // namespace sph::apps

#endif  // SPH_APPS_CAN_OPTIONS_HPP_
