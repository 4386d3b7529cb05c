// The SCMS devices on the bus as the acquisition and the bus simulation take them: the same
// settings, under the same names (--theta-cob-id, theta-cob-id = ... in a config file), configure
// sph_acquired and sph_cansim, so that one description serves both. DevicesConfig() checks them and
// turns them into the pipeline's device part.
#ifndef SPH_CAN_DEVICE_OPTIONS_HPP_
#define SPH_CAN_DEVICE_OPTIONS_HPP_

#include <cstdint>
#include <optional>
#include <vector>

#include "sph/can/pipeline.hpp"
#include "sph/core/valid_range.hpp"

namespace sph::can {

/// A CiA 406 encoder (--theta-*, --phi-*).
struct EncoderOptions {
  int node = 1;                  ///< CANopen node id (NMT, SDO, heartbeat, EMCY); 0: none
  std::uint32_t cob_id = 0x181;  ///< the TPDO carrying the position (11-bit id)
  int offset_byte = 0;
  int width_bytes = 4;
  std::uint64_t counts_per_rev = 1U << 24;
  int direction = 1;  ///< 1 or -1
  std::int64_t zero_counts = 0;
  bool multi_turn = false;
  int tpdo = 0;                ///< 0: from the COB-ID (predefined connection set)
  int sync_counter_byte = -1;  ///< the PDO byte with the SYNC counter; -1: none
};

/// The three devices and the SYNC (--probe-*, --sync-*).
struct DeviceOptions {
  EncoderOptions theta{1, 0x181};
  EncoderOptions phi{2, 0x182};
  int probe_node = 3;
  std::uint32_t probe_cob_id = 0x183;
  bool probe_extended_id = false;  ///< probe_cob_id is a 29-bit id
  int probe_offset_byte = 0;
  int probe_width_bytes = 4;
  bool probe_unsigned = false;
  bool probe_big_endian = false;
  double probe_scale_nm_per_count = 1.0;
  double probe_scale_um_per_count = 0.0;  ///< when set (> 0), replaces the nm scale
  double probe_offset_mm = 0.0;           ///< --probe-value-offset-mm: r = offset + scale * raw
  std::int64_t probe_over_range_raw = 0x7FFFFFFF;
  std::int64_t probe_under_range_raw = -0x7FFFFFFF - 1;
  bool probe_no_range_codes = false;
  std::vector<std::int64_t> probe_error_raw;
  int probe_status_byte = -1;
  int probe_status_error_mask = 0xFF;
  int probe_tpdo = 0;
  int probe_sync_counter_byte = -1;
  /// --probe-data-type: the value's CANopen data type (FindProbeDataType(): integer8 ... real32),
  /// which sets its width and signedness (and REAL32 decoding); empty: --probe-width-bytes and
  /// --probe-unsigned.
  std::string probe_data_type;
  std::uint32_t sync_cob_id = 0x80;
  int sync_counter_max = 0;  ///< 0: SYNC without counter; else 2..240
  /// SYNC period [ms]; not given: kDefaultSyncPeriodMs where SYNC is produced, else (a daemon
  /// following a producer, a replay) as observed. 0: not known (as not given).
  std::optional<double> sync_period_ms;
};

/// The SYNC period where none is given [ms].
inline constexpr double kDefaultSyncPeriodMs = 1.0;

/// The valid values of the device settings (the integers' ranges with unit "").
namespace ranges {
inline constexpr ValidRange kNodeId{0.0, 127.0, ""};
inline constexpr ValidRange kCobId{1.0, 0x7FF, ""};
inline constexpr ValidRange kProbeCobId{0.0, 0x1FFFFFFF, ""};  ///< 0x7FF unless probe_extended_id
inline constexpr ValidRange kOffsetByte{0.0, 7.0, ""};
inline constexpr ValidRange kWidthBytes{1.0, 8.0, ""};
inline constexpr ValidRange kCountsPerRev{1.0, 4294967295.0, "counts"};  ///< 6001h is UNSIGNED32
inline constexpr ValidRange kTpdo{0.0, 512.0, ""};
inline constexpr ValidRange kOptionalByte{-1.0, 7.0, ""};  ///< a byte of the PDO; -1: none
inline constexpr ValidRange kStatusErrorMask{1.0, 255.0, ""};
inline constexpr ValidRange kScaleNmPerCount{-1e9, 1e9, "nm"};
inline constexpr ValidRange kScaleUmPerCount{0.0, 1e6, "um", true};
inline constexpr ValidRange kValueOffsetMm{-1e4, 1e4, "mm"};
inline constexpr ValidRange kSyncCounterMax{0.0, 240.0, ""};
inline constexpr ValidRange kSyncPeriodMs{0.1, 60000.0, "ms"};
/// Times after the start of a simulation or acquisition, and durations: up to about three years.
inline constexpr ValidRange kRunTimeS{0.0, 1e8, "s"};
/// Times since the epoch that a frame time in ns (64 bits) can hold: up to the year 2261.
inline constexpr ValidRange kEpochTimeS{0.0, 9.2e9, "s", false, true};
}  // namespace ranges

/// The pipeline's device part (encoders, probe, SYNC id, counter, period) of `options`; a period
/// not given is kDefaultSyncPeriodMs. Throws sph::Error naming the option: a value out of its range
/// ("--theta-node: must be >= 0 and <= 127, got 128"), a position too narrow for its counts per
/// revolution, an 11-bit id above 0x7FF, a zero scale, a SYNC counter overflow value of 1, an
/// inconsistent set (two devices on one id: PipelineConfig::Validate()).
PipelineConfig DevicesConfig(const DeviceOptions& options);

}  // namespace sph::can

#endif  // SPH_CAN_DEVICE_OPTIONS_HPP_
