#include "sph/can/canopen.hpp"
#include "sph/can/device_options.hpp"

#include <limits>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"

namespace sph::can {
namespace {

TEST(Sync, WithAndWithoutCounter) {
  const CanFrame plain = EncodeSync();
  EXPECT_EQ(plain.id, 0x080U);
  EXPECT_EQ(plain.len, 0);
  ASSERT_TRUE(DecodeSync(plain).has_value());
  EXPECT_FALSE(DecodeSync(plain)->counter.has_value());
  const CanFrame counted = EncodeSync(std::uint8_t{17});
  EXPECT_EQ(counted.len, 1);
  EXPECT_EQ(DecodeSync(counted)->counter, std::optional<std::uint8_t>(17));
}

TEST(Sync, RejectsOtherIdsRemoteAndLongFrames) {
  EXPECT_FALSE(DecodeSync(MakeFrame(0x081, {})).has_value());
  CanFrame rtr = EncodeSync();
  rtr.id |= kRtrFlag;
  EXPECT_FALSE(DecodeSync(rtr).has_value());
  EXPECT_FALSE(DecodeSync(MakeFrame(0x080, {1, 2})).has_value());
  EXPECT_TRUE(DecodeSync(MakeFrame(0x100, {}), 0x100).has_value());
}

TEST(Sync, CounterWrapsAndGapsAreCounted) {
  EXPECT_EQ(NextSyncCounter(1, 240), 2);
  EXPECT_EQ(NextSyncCounter(240, 240), 1);
  EXPECT_EQ(NextSyncCounter(5, 5), 1);
  EXPECT_EQ(MissedSyncs(3, 4, 240), 0);
  EXPECT_EQ(MissedSyncs(3, 6, 240), 2);
  EXPECT_EQ(MissedSyncs(240, 1, 240), 0);  // the wrap itself
  EXPECT_EQ(MissedSyncs(239, 2, 240), 2);  // 240 and 1 missing
  EXPECT_EQ(MissedSyncs(7, 7, 240), 239);  // a full round missing
}

TEST(Heartbeat, DecodesNodeAndState) {
  const auto hb = DecodeHeartbeat(MakeFrame(0x705, {0x05}));
  ASSERT_TRUE(hb.has_value());
  EXPECT_EQ(hb->node_id, 5);
  EXPECT_EQ(hb->state, 0x05);
  EXPECT_EQ(NmtStateName(hb->state), "operational");
  EXPECT_EQ(NmtStateName(0x7F), "pre-operational");
  EXPECT_EQ(NmtStateName(0x12), "unknown state 0x12");
  EXPECT_FALSE(DecodeHeartbeat(MakeFrame(0x700, {0x05})).has_value());  // node 0 does not exist
  EXPECT_FALSE(DecodeHeartbeat(MakeFrame(0x705, {})).has_value());      // short
  EXPECT_FALSE(DecodeHeartbeat(MakeFrame(0x705, {5, 0})).has_value());  // long
  const CanFrame enc = EncodeHeartbeat(127, NmtState::kStopped);
  EXPECT_EQ(enc.id, 0x77FU);
  EXPECT_EQ(enc.data[0], 0x04);
}

TEST(Emergency, DecodesCodeRegisterAndData) {
  const CanFrame f = MakeFrame(0x083, {0x30, 0x81, 0x11, 1, 2, 3, 4, 5});
  ASSERT_TRUE(IsEmergencyId(f));
  const auto e = DecodeEmergency(f);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->node_id, 3);
  EXPECT_EQ(e->error_code, 0x8130);
  EXPECT_EQ(e->error_register, 0x11);
  EXPECT_EQ(e->manufacturer[4], 5);
  EXPECT_NE(DescribeEmergency(*e).find("0x8130 (communication: life guard or heartbeat error)"), std::string::npos);
  EXPECT_EQ(EncodeEmergency(*e).data, f.data);
  EXPECT_FALSE(DecodeEmergency(MakeFrame(0x083, {0x30, 0x81})).has_value());  // short: malformed
  EXPECT_TRUE(IsEmergencyId(MakeFrame(0x083, {0x30, 0x81})));
  EXPECT_FALSE(IsEmergencyId(EncodeSync()));  // 0x080 is SYNC, not node 0's EMCY
}

TEST(Field, LittleAndBigEndianSignedAndUnsigned) {
  const CanFrame f = MakeFrame(0x181, {0x11, 0xFE, 0xFF, 0xFF, 0xFF, 0x80});
  EXPECT_EQ(ExtractField(f, {0x181, 0, 4, false, false}), std::optional<std::int64_t>(0xFFFFFE11));
  EXPECT_EQ(ExtractField(f, {0x181, 1, 4, true, false}), std::optional<std::int64_t>(-2));
  EXPECT_EQ(ExtractField(f, {0x181, 0, 2, false, true}), std::optional<std::int64_t>(0x11FE));
  EXPECT_EQ(ExtractField(f, {0x181, 5, 1, true, false}), std::optional<std::int64_t>(-128));
  EXPECT_FALSE(ExtractField(f, {0x181, 4, 4, false, false}).has_value());  // needs 8 bytes, has 6
  CanFrame g;
  InsertField(g, {0x181, 2, 3, true, true}, -2);
  EXPECT_EQ(g.len, 5);
  EXPECT_EQ(g.data[2], 0xFF);
  EXPECT_EQ(g.data[4], 0xFE);
  EXPECT_EQ(ExtractField(g, {0x181, 2, 3, true, true}), std::optional<std::int64_t>(-2));
}

TEST(Field, LayoutValidation) {
  EXPECT_THROW(ValidateLayout({0x181, 6, 4, false, false}, "theta"), Error);
  EXPECT_THROW(ValidateLayout({0x181, 0, 0, false, false}, "theta"), Error);
  EXPECT_THROW(ValidateLayout({0x800, 0, 4, false, false}, "theta"), Error);
  EXPECT_NO_THROW(ValidateLayout({0x12345678 | kEffFlag, 0, 8, false, false}, "probe"));
  try {
    ValidateLayout({0x181, 6, 4, false, false}, "theta encoder");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "theta encoder: a 4-byte value at byte 6 does not fit in 8 data bytes");
  }
}

EncoderConfig Encoder(std::uint64_t cpr, int dir, std::int64_t zero, bool multi, int width = 4) {
  EncoderConfig c;
  c.field = {0x181, 0, width, false, false};
  c.counts_per_rev = cpr;
  c.direction = dir;
  c.zero_offset_counts = zero;
  c.multi_turn = multi;
  return c;
}

CanFrame PositionFrame(const EncoderConfig& c, std::int64_t raw) {
  CanFrame f;
  f.id = c.field.can_id;
  InsertField(f, c.field, raw);
  return f;
}

TEST(Encoder, SingleTurnCountsToDegrees) {
  const auto c = Encoder(4096, 1, 0, false);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 1024)).value, 90.0);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 0)).value, 0.0);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 4095)).value, 360.0 * 4095 / 4096);
  EXPECT_EQ(DecodePosition(c, PositionFrame(c, 4096)).status, DecodeStatus::kOutOfRange);
}

TEST(Encoder, ZeroOffsetAndDirectionWrapIntoOneTurn) {
  const auto c = Encoder(4096, 1, 1000, false);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 1000)).value, 0.0);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 0)).value, 360.0 * 3096 / 4096);  // below zero wraps
  const auto r = Encoder(4096, -1, 1000, false);
  EXPECT_DOUBLE_EQ(DecodePosition(r, PositionFrame(r, 0)).value, 360.0 * 1000 / 4096);
  EXPECT_DOUBLE_EQ(DecodePosition(r, PositionFrame(r, 2024)).value, 360.0 * 3072 / 4096);  // -1024 counts
}

TEST(Encoder, MultiTurnIsContinuousAcrossTheCounterWrap) {
  // 16-bit counter, 1024 counts per turn: 64 turns before the raw value wraps.
  const auto c = Encoder(1024, 1, 65000, true, 2);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 65000)).value, 0.0);
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 464)).value, 360.0 * 1000 / 1024);  // past the wrap
  EXPECT_DOUBLE_EQ(DecodePosition(c, PositionFrame(c, 64000)).value, -360.0 * 1000 / 1024);
  EXPECT_DOUBLE_EQ(
      DecodePosition(Encoder(1024, 1, 0, true), PositionFrame(Encoder(1024, 1, 0, true), 3 * 1024 + 256)).value,
      3 * 360.0 + 90.0);
}

TEST(Encoder, ShortFrameIsMalformed) {
  const auto c = Encoder(4096, 1, 0, false);
  EXPECT_EQ(DecodePosition(c, MakeFrame(0x181, {1, 2, 3})).status, DecodeStatus::kShort);
}

TEST(Encoder, EncodeIsTheInverseOfDecode) {
  for (const auto& c :
       {Encoder(1U << 24, 1, 12345, false), Encoder(1U << 24, -1, 777, false), Encoder(1U << 20, -1, 5, true)}) {
    for (double a : {0.0, 7.5, 172.5, 345.0}) {
      const double back = DecodePosition(c, PositionFrame(c, EncodePositionRaw(c, a))).value;
      EXPECT_NEAR(back, a, 0.5 * 360.0 / static_cast<double>(c.counts_per_rev)) << a;
    }
  }
}

// The extremes of a 64-bit field: the arithmetic stays on the counter's circle, never overflows.
TEST(Encoder, SixtyFourBitFieldsAtTheirExtremes) {
  constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  // Single turn, the largest counts per revolution: zero offsets far from the raw value.
  const auto big = Encoder(static_cast<std::uint64_t>(kMax), 1, kMax - 1, false, 8);
  EXPECT_DOUBLE_EQ(DecodePosition(big, PositionFrame(big, kMax - 1)).value, 0.0);
  const auto big_back = Encoder(static_cast<std::uint64_t>(kMax), -1, -1, false, 8);
  const DecodedValue v = DecodePosition(big_back, PositionFrame(big_back, kMax / 2));
  EXPECT_EQ(v.status, DecodeStatus::kOk);
  EXPECT_NEAR(v.value, 180.0, 1e-9);
  // Multi-turn, reversed: -(-2^63) is -2^63 on a 64-bit counter.
  const auto multi = Encoder(1U << 20, -1, 0, true, 8);
  EXPECT_DOUBLE_EQ(DecodePosition(multi, PositionFrame(multi, kMin)).value, 360.0 * -0x1p63 / 0x1p20);
  EXPECT_DOUBLE_EQ(DecodePosition(multi, PositionFrame(multi, kMax)).value,
                   360.0 * -static_cast<double>(kMax) / 0x1p20);
  const auto multi_zero = Encoder(1U << 20, -1, kMin, true, 8);
  EXPECT_DOUBLE_EQ(DecodePosition(multi_zero, PositionFrame(multi_zero, kMax)).value, 360.0 / 0x1p20);
  // Encoding from a zero offset at the end of the range wraps like the counter.
  const auto enc = Encoder(1U << 20, -1, kMin, true, 8);
  EXPECT_NEAR(DecodePosition(enc, PositionFrame(enc, EncodePositionRaw(enc, 90.0))).value, 90.0, 1e-9);
}

TEST(Encoder, Validation) {
  EXPECT_THROW(ValidateEncoder(Encoder(0, 1, 0, false), "theta"), Error);
  EXPECT_THROW(ValidateEncoder(Encoder(std::uint64_t{1} << 63, 1, 0, false), "theta"), Error);
  EXPECT_NO_THROW(ValidateEncoder(Encoder((std::uint64_t{1} << 63) - 1, 1, 0, false), "theta"));
  EXPECT_THROW(ValidateEncoder(Encoder(4096, 2, 0, false), "theta"), Error);
  EXPECT_NO_THROW(ValidateEncoder(Encoder(4096, -1, 0, false), "theta"));
}

TEST(Probe, ScaleOffsetAndSign) {
  ProbeConfig p;  // signed 32 bit LE, 1 nm per count
  CanFrame f;
  f.id = 0x183;
  InsertField(f, p.field, 5123456);
  EXPECT_DOUBLE_EQ(DecodeProbe(p, f).value, 5.123456);
  InsertField(f, p.field, -2500);
  EXPECT_DOUBLE_EQ(DecodeProbe(p, f).value, -0.0025);
  p.scale_mm_per_count = 0.1e-3;  // 0.1 um per count
  p.offset_mm = 4.0;
  EXPECT_DOUBLE_EQ(DecodeProbe(p, f).value, 4.0 - 0.25);
}

// A REAL32 value (IEEE 754 single, little endian): 1.5 is 0x3FC00000, -0.375 0xBEC00000; times
// the scale, plus the offset. NaN is a device error, an infinity out of range.
TEST(Probe, Real32ValuesByTheirDataType) {
  DeviceOptions o;
  o.probe_data_type = "real32";
  o.probe_scale_um_per_count = 1000.0;  // the probe sends mm
  o.probe_offset_mm = 2.0;
  const ProbeConfig p = DevicesConfig(o).probe;
  EXPECT_TRUE(p.real32);
  EXPECT_EQ(p.field.width_bytes, 4);
  EXPECT_DOUBLE_EQ(DecodeProbe(p, MakeFrame(0x183, {0x00, 0x00, 0xC0, 0x3F})).value, 3.5);
  EXPECT_DOUBLE_EQ(DecodeProbe(p, MakeFrame(0x183, {0x00, 0x00, 0xC0, 0xBE})).value, 1.625);
  EXPECT_EQ(DecodeProbe(p, MakeFrame(0x183, {0x00, 0x00, 0xC0, 0x7F})).status, DecodeStatus::kDeviceError);  // NaN
  EXPECT_EQ(DecodeProbe(p, MakeFrame(0x183, {0x00, 0x00, 0x80, 0xFF})).status, DecodeStatus::kOutOfRange);   // -inf
  EXPECT_EQ(DecodeProbe(p, MakeFrame(0x183, {0x00, 0x00, 0xC0})).status, DecodeStatus::kShort);
  EXPECT_EQ(EncodeProbeRaw(p, 3.5), 0x3FC00000);
  // The integer types set width and sign: INTEGER16 -2 is FE FF.
  o.probe_data_type = "integer16";
  o.probe_scale_um_per_count = 1.0;
  o.probe_offset_mm = 0.0;
  const ProbeConfig i16 = DevicesConfig(o).probe;
  EXPECT_DOUBLE_EQ(DecodeProbe(i16, MakeFrame(0x183, {0xFE, 0xFF})).value, -0.002);
  o.probe_data_type = "unsigned8";
  EXPECT_DOUBLE_EQ(DecodeProbe(DevicesConfig(o).probe, MakeFrame(0x183, {0xFE})).value, 0.254);
  o.probe_data_type = "real64";
  EXPECT_THROW(DevicesConfig(o), Error);
}

TEST(Probe, RangeAndErrorCodesAreFlagged) {
  ProbeConfig p;
  p.error_raw = {0x7FFFFFFE};
  CanFrame f;
  f.id = 0x183;
  InsertField(f, p.field, 0x7FFFFFFF);
  EXPECT_EQ(DecodeProbe(p, f).status, DecodeStatus::kOutOfRange);
  InsertField(f, p.field, -0x7FFFFFFF - 1);
  EXPECT_EQ(DecodeProbe(p, f).status, DecodeStatus::kOutOfRange);
  InsertField(f, p.field, 0x7FFFFFFE);
  EXPECT_EQ(DecodeProbe(p, f).status, DecodeStatus::kDeviceError);
  EXPECT_EQ(DecodeProbe(p, MakeFrame(0x183, {1, 2})).status, DecodeStatus::kShort);
}

TEST(Probe, RawSensorFrameWithStatusByte) {
  // A sensor with its own frame: 29-bit id, big-endian unsigned 24-bit value at byte 1,
  // status byte 0 where bit 0x80 means "no target".
  ProbeConfig p;
  p.node_id = 0;
  p.field = {0x18FF0010 | kEffFlag, 1, 3, false, true};
  p.scale_mm_per_count = 1e-4;
  p.over_range_raw = 0xFFFFFF;
  p.under_range_raw.reset();
  p.status_offset_byte = 0;
  p.status_error_mask = 0x80;
  ASSERT_NO_THROW(ValidateProbe(p, "probe"));
  CanFrame ok = MakeFrame(0, {0x01, 0x00, 0xC3, 0x50});
  ok.id = p.field.can_id;
  EXPECT_DOUBLE_EQ(DecodeProbe(p, ok).value, 5.0);  // 50000 * 0.1 um
  CanFrame bad = ok;
  bad.data[0] = 0x81;
  EXPECT_EQ(DecodeProbe(p, bad).status, DecodeStatus::kDeviceError);
  CanFrame shorter = MakeFrame(0, {0x01, 0x00, 0xC3});
  EXPECT_EQ(DecodeProbe(p, shorter).status, DecodeStatus::kShort);
}

TEST(Probe, EncodeNeverProducesAFlagValue) {
  ProbeConfig p;
  EXPECT_EQ(EncodeProbeRaw(p, 5.0), 5000000);
  EXPECT_EQ(EncodeProbeRaw(p, 1e9), 0x7FFFFFFE);
  EXPECT_EQ(EncodeProbeRaw(p, -1e9), -0x7FFFFFFF);
}

}  // namespace
}  // namespace sph::can
