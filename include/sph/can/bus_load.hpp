// The load the acquisition puts on the bus: per SYNC period the SYNC and each device's TPDO,
// plus the nodes' heartbeats, in bits as a classic CAN frame needs them at worst (stuff bits
// included), against the bitrate. The acquisition refuses a SYNC period the bus cannot carry and
// warns above half its capacity; without --sync-period-ms it chooses the shortest period of
// kSyncPeriodChoicesMs under half. The counting, with figures: docs/method/acquisition.md.
#ifndef SPH_CAN_BUS_LOAD_HPP_
#define SPH_CAN_BUS_LOAD_HPP_

#include <array>
#include <string>

#include "sph/can/pipeline.hpp"

namespace sph::can {

/// The bits a classic CAN data frame of `data_bytes` bytes takes on the bus at worst: the frame
/// (44 bits for an 11-bit id, 64 for a 29-bit id, plus 8 per data byte), the interframe space
/// (3), and the stuff bits of its stuffed part (one per 4 bits after the first).
int FrameBits(int data_bytes, bool extended);

/// The bus's share of one SYNC cycle.
struct BusLoad {
  int frames_per_sync = 0;  ///< the SYNC and one TPDO per device
  int bits_per_sync = 0;    ///< their bits at worst
  double heartbeat_bits_per_s = 0.0;
  double bits_per_s = 0.0;  ///< all of it, at the SYNC period
  double load = 0.0;        ///< bits_per_s / bitrate (1: the bus is full)
};

/// The load of `devices`' SYNC and TPDOs every `sync_period_s` and of `heartbeat_nodes` nodes'
/// heartbeats every `heartbeat_ms` (0: none) on a bus of `bitrate_bit_s`. A TPDO's length is the
/// bytes its configured fields reach (the value, a status byte, a SYNC counter byte).
BusLoad SyncLoad(const PipelineConfig& devices, double sync_period_s, double bitrate_bit_s, int heartbeat_nodes,
                 double heartbeat_ms);

/// The SYNC periods chosen from when none is given [ms], shortest first.
inline constexpr std::array<double, 8> kSyncPeriodChoicesMs{1, 2, 5, 10, 20, 50, 100, 1000};

/// The shortest period of kSyncPeriodChoicesMs whose load is at most half the bus [s]; the longest
/// when none is.
double DefaultSyncPeriodS(const PipelineConfig& devices, double bitrate_bit_s, int heartbeat_nodes,
                          double heartbeat_ms);

/// "340 bits a SYNC cycle (SYNC and 3 TPDOs) and heartbeats: 68.2 % of a 500 kbit/s bus at a
/// 1 ms SYNC period".
std::string DescribeLoad(const BusLoad& load, double sync_period_s, double bitrate_bit_s);

}  // namespace sph::can

#endif  // SPH_CAN_BUS_LOAD_HPP_
