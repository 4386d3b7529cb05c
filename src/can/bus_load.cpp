// The bus load of the acquisition's SYNC cycle.
#include "sph/can/bus_load.hpp"

#include <algorithm>

#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

// The bytes a device's TPDO carries: as far as its configured fields reach.
int PdoBytes(const FieldLayout& field, int status_byte, int counter_byte) {
  return std::max({field.offset_byte + field.width_bytes, status_byte + 1, counter_byte + 1});
}

}  // namespace

int FrameBits(int data_bytes, bool extended) {
  // SOF, id, control, data and CRC are stuffed (34 bits + data for 11-bit ids, 54 for 29-bit);
  // CRC delimiter, ACK, EOF (10 bits) and the interframe space (3) are not.
  const int stuffed = (extended ? 54 : 34) + 8 * data_bytes;
  return stuffed + 13 + (stuffed - 1) / 4;
}

BusLoad SyncLoad(const PipelineConfig& c, double sync_period_s, double bitrate_bit_s, int heartbeat_nodes,
                 double heartbeat_ms) {
  BusLoad l;
  l.frames_per_sync = 1 + kNumDevices;
  l.bits_per_sync = FrameBits(c.sync_counter_max != 0 ? 1 : 0, false);
  const FieldLayout* fields[] = {&c.theta.field, &c.phi.field, &c.probe.field};
  for (int d = 0; d < kNumDevices; ++d) {
    const FieldLayout& f = *fields[d];
    l.bits_per_sync += FrameBits(
        PdoBytes(f, d == kProbe ? c.probe.status_offset_byte : -1, c.sync_counter_byte[static_cast<std::size_t>(d)]),
        (f.can_id & kEffFlag) != 0);
  }
  if (heartbeat_ms > 0.0) l.heartbeat_bits_per_s = heartbeat_nodes * FrameBits(1, false) * 1000.0 / heartbeat_ms;
  l.bits_per_s = l.bits_per_sync / sync_period_s + l.heartbeat_bits_per_s;
  l.load = bitrate_bit_s > 0.0 ? l.bits_per_s / bitrate_bit_s : 0.0;
  return l;
}

double DefaultSyncPeriodS(const PipelineConfig& c, double bitrate_bit_s, int heartbeat_nodes, double heartbeat_ms) {
  for (const double ms : kSyncPeriodChoicesMs) {
    if (SyncLoad(c, ms * 1e-3, bitrate_bit_s, heartbeat_nodes, heartbeat_ms).load <= 0.5) return ms * 1e-3;
  }
  return kSyncPeriodChoicesMs.back() * 1e-3;
}

std::string DescribeLoad(const BusLoad& l, double sync_period_s, double bitrate_bit_s) {
  return internal::Format(
      "%d bits a SYNC cycle (SYNC and %d TPDOs)%s: %.1f %% of a %g kbit/s bus at a %g ms SYNC "
      "period",
      l.bits_per_sync, l.frames_per_sync - 1, l.heartbeat_bits_per_s > 0.0 ? " and heartbeats" : "", 100.0 * l.load,
      bitrate_bit_s * 1e-3, sync_period_s * 1e3);
}

}  // namespace sph::can
