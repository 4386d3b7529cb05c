// Device options shared by sph_acquired and sph_cansim: the same names configure the daemon and
// the simulated machine, so one config file serves both.
#ifndef SPH_APPS_CAN_OPTIONS_HPP_
#define SPH_APPS_CAN_OPTIONS_HPP_

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

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
  double sync_period_ms = 1.0;
};

/// Adds the --theta-*, --phi-*, --probe-* and --sync-* options, in option group "Devices".
void AddDeviceOptions(CLI::App& app, DeviceOptions& options);

/// The pipeline's device part (encoders, probe, SYNC id, counter, period) from the options.
/// Throws sph::Error on an inconsistent set.
void ApplyDeviceOptions(const DeviceOptions& options, can::PipelineConfig& config);

}  // namespace sph::apps

#endif  // SPH_APPS_CAN_OPTIONS_HPP_
