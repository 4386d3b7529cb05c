// The bus load of the SYNC cycle against hand-worked frame lengths (classic CAN, worst-case stuff
// bits: 47 + 8n + floor((34 + 8n - 1) / 4) bits for an 11-bit id and n data bytes).
#include "sph/can/bus_load.hpp"

#include <gtest/gtest.h>

#include "sph/can/socket.hpp"

namespace sph::can {
namespace {

TEST(BusLoad, FrameBitsAtWorst) {
  EXPECT_EQ(FrameBits(0, false), 55);   // 47 + 0 + 8
  EXPECT_EQ(FrameBits(1, false), 65);   // 47 + 8 + 10
  EXPECT_EQ(FrameBits(4, false), 95);   // 47 + 32 + 16
  EXPECT_EQ(FrameBits(8, false), 135);  // 47 + 64 + 24
  EXPECT_EQ(FrameBits(8, true), 160);   // 67 + 64 + 29
}

// The default devices (three 4-byte TPDOs, SYNC without counter) and three nodes' 100 ms
// heartbeats: 55 + 3 * 95 = 340 bits a cycle, 3 * 65 * 10 = 1950 bit/s of heartbeats.
TEST(BusLoad, TheDefaultDevicesAtEachBitrate) {
  const PipelineConfig c;
  const double rates[] = {125e3, 250e3, 500e3, 1000e3};
  const double at_1ms[] = {341950.0 / 125e3, 341950.0 / 250e3, 341950.0 / 500e3, 341950.0 / 1000e3};
  const double chosen_ms[] = {10, 5, 2, 1};  // the shortest of 1, 2, 5, 10, ... ms at half the bus or less
  for (int i = 0; i < 4; ++i) {
    const BusLoad l = SyncLoad(c, 1e-3, rates[i], 3, 100.0);
    EXPECT_EQ(l.bits_per_sync, 340);
    EXPECT_EQ(l.frames_per_sync, 4);
    EXPECT_DOUBLE_EQ(l.heartbeat_bits_per_s, 1950.0);
    EXPECT_NEAR(l.load, at_1ms[i], 1e-12) << rates[i];
    const double period_s = DefaultSyncPeriodS(c, rates[i], 3, 100.0);
    EXPECT_DOUBLE_EQ(period_s, chosen_ms[i] * 1e-3) << rates[i];
    EXPECT_NEAR(SyncLoad(c, period_s, rates[i], 3, 100.0).load, (340.0 / period_s + 1950.0) / rates[i], 1e-12);
  }
  EXPECT_EQ(DescribeLoad(SyncLoad(c, 1e-3, 500e3, 3, 100.0), 1e-3, 500e3),
            "340 bits a SYNC cycle (SYNC and 3 TPDOs) and heartbeats: 68.4 % of a 500 kbit/s bus at a 1 ms SYNC "
            "period");
  // A SYNC counter adds a byte to the SYNC; a TPDO is as long as its configured fields reach (a
  // 2-byte value and the counter in byte 2: 3 bytes).
  PipelineConfig counted;
  counted.sync_counter_max = 240;
  counted.theta.field.width_bytes = 2;
  counted.sync_counter_byte = {2, -1, -1};
  EXPECT_EQ(SyncLoad(counted, 1e-3, 500e3, 3, 0.0).bits_per_sync, 65 + 85 + 95 + 95);  // 3 bytes: 47 + 24 + 14
}

// The kernel reports a bitrate only for a CAN controller's interface (IFLA_CAN_BITTIMING): none
// for the loopback interface, which has no CAN data, nor for one that does not exist.
TEST(BusLoad, NoBitrateWhereTheKernelReportsNone) {
  EXPECT_FALSE(InterfaceBitrate("lo").has_value());
  EXPECT_FALSE(InterfaceBitrate("nosuchcan9").has_value());
  EXPECT_FALSE(InterfaceBitrate("").has_value());
}

}  // namespace
}  // namespace sph::can
