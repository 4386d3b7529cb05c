#include "sph/can/error_frame.hpp"

#include <gtest/gtest.h>

namespace sph::can {
namespace {

TEST(ErrorFrame, NotAnErrorFrame) { EXPECT_FALSE(DecodeErrorFrame(MakeFrame(0x123, {1})).has_value()); }

TEST(ErrorFrame, BusOff) {
  // What `cansend vcan0 20000040#0000000000000000` puts on the bus.
  CanFrame f = MakeFrame(0, {0, 0, 0, 0, 0, 0, 0, 0});
  f.id = 0x20000040;
  const auto e = DecodeErrorFrame(f);
  ASSERT_TRUE(e.has_value());
  EXPECT_TRUE(e->bus_off);
  EXPECT_EQ(e->classes, kErrBusOff);
  EXPECT_EQ(e->text, "bus-off");
}

TEST(ErrorFrame, ControllerDetailsAndPassiveState) {
  const auto e = DecodeErrorFrame(MakeErrorFrame(kErrController, {0, 0x14}));
  ASSERT_TRUE(e.has_value());
  EXPECT_TRUE(e->error_passive);
  EXPECT_FALSE(e->bus_off);
  EXPECT_EQ(e->text, "controller-problem{rx-error-warning,rx-error-passive}");
  EXPECT_TRUE(DecodeErrorFrame(MakeErrorFrame(kErrController, {0, 0x01}))->controller_overflow);
}

TEST(ErrorFrame, SeveralClassesInOneFrame) {
  const auto e = DecodeErrorFrame(
      MakeErrorFrame(kErrProtocol | kErrNoAck | kErrCounters | kErrLostArbitration, {5, 0, 0x04, 0x0A, 0, 0, 97, 128}));
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->text,
            "lost-arbitration{at bit 5}, protocol-violation{bit-stuffing-error}{location 0x0A}, "
            "no-acknowledgement-on-tx, error-counter{tx 97, rx 128}");
  EXPECT_EQ(e->tx_error_counter, std::optional<std::uint8_t>(97));
  EXPECT_EQ(e->rx_error_counter, std::optional<std::uint8_t>(128));
}

TEST(ErrorFrame, ShortDataReadsAsZeroAndUnknownClassesAreNamed) {
  CanFrame f;
  f.id = kErrFlag | kErrController | 0x10000;
  f.len = 0;
  const auto e = DecodeErrorFrame(f);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->text, "controller-problem, unknown-classes{0x10000}");
}

TEST(ErrorFrame, DefaultMaskLeavesOutFloodingClasses) {
  EXPECT_EQ(kDefaultErrorMask & kErrBusError, 0U);
  EXPECT_EQ(kDefaultErrorMask & kErrLostArbitration, 0U);
  EXPECT_NE(kDefaultErrorMask & kErrBusOff, 0U);
}

}  // namespace
}  // namespace sph::can
