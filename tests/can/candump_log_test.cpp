#include "sph/can/candump_log.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "sph/can/canopen.hpp"
#include "sph/can/error_frame.hpp"
#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph::can {
namespace {

TEST(CandumpLine, FormatsLikeCandump) {
  CanFrame f = MakeFrame(0x181, {0x00, 0x10, 0xAB, 0xFF}, 1700000000123456789LL);
  EXPECT_EQ(FormatCandumpLine(f, "vcan0"), "(1700000000.123456) vcan0 181#0010ABFF");
  CanFrame sync = EncodeSync();
  sync.t_ns = 5'000'000'000LL;
  EXPECT_EQ(FormatCandumpLine(sync, "can0"), "(0000000005.000000) can0 080#");
  CanFrame eff = MakeFrame(0, {1, 2});
  eff.id = 0x12345678 | kEffFlag;
  EXPECT_EQ(FormatCandumpLine(eff, "can0"), "(0000000000.000000) can0 12345678#0102");
  EXPECT_EQ(FormatCandumpLine(MakeErrorFrame(kErrBusOff), "can0"),
            "(0000000000.000000) can0 20000040#0000000000000000");
  CanFrame rtr = MakeFrame(0x123, {});
  rtr.id |= kRtrFlag;
  EXPECT_EQ(FormatCandumpLine(rtr, "can0"), "(0000000000.000000) can0 123#R");
  rtr.len = 3;
  EXPECT_EQ(FormatCandumpLine(rtr, "can0"), "(0000000000.000000) can0 123#R3");
}

TEST(CandumpLine, ParsesEveryKind) {
  CanFrame f;
  std::string iface, error;
  ASSERT_TRUE(ParseCandumpLine("(1436509052.249713) vcan0 044#2A366C2BBA", f, iface, error)) << error;
  EXPECT_EQ(f.t_ns, 1436509052249713000LL);
  EXPECT_EQ(iface, "vcan0");
  EXPECT_EQ(f.id, 0x044U);
  EXPECT_EQ(f.len, 5);
  EXPECT_EQ(f.data[4], 0xBA);
  ASSERT_TRUE(ParseCandumpLine("(1.5) can1 12345678#01.02.03\r", f, iface, error)) << error;
  EXPECT_EQ(f.id, 0x12345678U | kEffFlag);
  EXPECT_EQ(f.len, 3);
  EXPECT_EQ(f.t_ns, 1'500'000'000LL);
  ASSERT_TRUE(ParseCandumpLine("(0.000001) can0 20000004#0004000000000000", f, iface, error)) << error;
  EXPECT_TRUE(f.IsError());
  EXPECT_FALSE(f.IsExtended());
  EXPECT_EQ(f.id & kErrMask, 0x4U);
  ASSERT_TRUE(ParseCandumpLine("(0.000001) can0 7FF#R2", f, iface, error)) << error;
  EXPECT_TRUE(f.IsRemote());
  EXPECT_EQ(f.len, 2);
  ASSERT_TRUE(ParseCandumpLine("(0.000001) can0 080#", f, iface, error)) << error;
  EXPECT_EQ(f.len, 0);
}

TEST(CandumpLine, RoundTrip) {
  for (const CanFrame& f0 : {MakeFrame(0x183, {1, 2, 3, 4, 5, 6, 7, 8}, 1700000000000001000LL),
                             MakeErrorFrame(kErrController, {0, 4}), EncodeSync(std::uint8_t{3})}) {
    CanFrame f;
    std::string iface, error;
    ASSERT_TRUE(ParseCandumpLine(FormatCandumpLine(f0, "vcan0"), f, iface, error)) << error;
    EXPECT_EQ(f.id, f0.id);
    EXPECT_EQ(f.len, f0.len);
    EXPECT_EQ(f.data, f0.data);
    EXPECT_EQ(f.t_ns, f0.t_ns / 1000 * 1000);
  }
}

TEST(CandumpLine, MalformedLinesSayWhy) {
  CanFrame f;
  std::string iface, error;
  auto why = [&](const char* line) {
    error.clear();
    EXPECT_FALSE(ParseCandumpLine(line, f, iface, error)) << line;
    return error;
  };
  EXPECT_EQ(why("1436509052.249713 vcan0 044#2A"), "expected '(seconds.microseconds)' at the start");
  EXPECT_EQ(why("(1436509052.249713)"), "no interface name");
  EXPECT_EQ(why("(1.0) vcan0"), "no frame after the interface name");
  EXPECT_EQ(why("(1.0) vcan0 0442A"), "expected 'id#data', got '0442A'");
  EXPECT_EQ(why("(1.0) vcan0 44#2A"), "CAN id '44' must have 3 (11 bit) or 8 (29 bit) hex digits");
  EXPECT_EQ(why("(1.0) vcan0 800#2A"), "11-bit CAN id '800' is larger than 7FF");
  EXPECT_EQ(why("(1.0) vcan0 181#2G"), "bad data byte '2G'");
  EXPECT_EQ(why("(1.0) vcan0 181#123"), "bad data byte '3'");
  EXPECT_EQ(why("(1.0) vcan0 181#010203040506070809"), "more than 8 data bytes");
  EXPECT_EQ(why("(1.0) vcan0 181##10011"), "CAN FD frames ('##') are not supported");
  EXPECT_EQ(why("(1.0) vcan0 181#01 extra"), "unexpected text after the frame: 'extra'");
  EXPECT_EQ(why("(1.0) vcan0 20000040#R"), "an error frame cannot be a remote frame: '20000040#R'");
  // Times whose nanoseconds do not fit in 64 bits (after the year 2262).
  EXPECT_EQ(why("(17000000000.000000) vcan0 080#"), "time 17000000000 s is out of range (at most 9223372035)");
  EXPECT_EQ(why("(999999999999.999999) vcan0 080#"), "time 999999999999 s is out of range (at most 9223372035)");
  ASSERT_TRUE(ParseCandumpLine("(9223372035.999999) vcan0 080#", f, iface, error)) << error;
  EXPECT_EQ(f.t_ns, 9223372035999999000);
}

TEST(CandumpReader, ReportsMalformedLinesWithLineNumbersAndGoesOn) {
  std::istringstream in("(1.000000) can0 080#\n\nnot a frame\n(1.000100) can0 181#00000000\n");
  CandumpReader reader(in, "x.log");
  EXPECT_EQ(reader.Next().status, CandumpReader::Status::kFrame);
  const auto bad = reader.Next();
  EXPECT_EQ(bad.status, CandumpReader::Status::kMalformed);
  EXPECT_EQ(bad.error, "x.log:3: expected '(seconds.microseconds)' at the start");
  const auto ok = reader.Next();
  ASSERT_EQ(ok.status, CandumpReader::Status::kFrame);
  EXPECT_EQ(ok.frame.id, 0x181U);
  EXPECT_EQ(reader.Next().status, CandumpReader::Status::kEnd);
}

TEST(CandumpWriter, AppendsAndCanUtilsReadsIt) {
  const std::string dir = sph::testing::MakeTempDir("candump_writer");
  const std::string path = dir + "/frames.log";
  {
    CandumpWriter w(path, "vcan0", 0.0);
    w.Write(MakeFrame(0x080, {}, 1700000000000000000LL));
    w.Write(MakeFrame(0x181, {1, 2, 3, 4}, 1700000000000100000LL));
    w.Close();
  }
  {
    CandumpWriter w(path, "vcan0", 0.0);  // a restart appends
    w.Write(MakeErrorFrame(kErrBusOff));
    w.Close();
  }
  CandumpReader r(path);
  int n = 0;
  while (r.Next().status == CandumpReader::Status::kFrame) ++n;
  EXPECT_EQ(n, 3);
  if (std::system("command -v log2asc >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "can-utils' log2asc is not installed: the cross-check with can-utils is skipped";
  }
  const std::string asc = dir + "/frames.asc";
  ASSERT_EQ(std::system(("log2asc -I '" + path + "' vcan0 > '" + asc + "'").c_str()), 0);
  std::ifstream in(asc);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_NE(ss.str().find("181             Rx   d 4 01 02 03 04"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("ErrorFrame"), std::string::npos) << ss.str();
}

TEST(CandumpWriter, RefusesAFileThatIsNoCandumpLogUntouched) {
  const std::string dir = sph::testing::MakeTempDir("candump_notes");
  const std::string path = dir + "/notes.txt";
  const std::string text = "# sph-points 1\n0 7.5 4.9";  // a points file, its last line cut short
  { std::ofstream(path, std::ios::binary) << text; }
  try {
    CandumpWriter w(path, "can0", 0.0);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), path +
                                         ": is not a candump log (line 1: expected '(seconds.microseconds)' at the "
                                         "start): refusing to append to it; use another file");
  }
  EXPECT_EQ(sph::testing::ReadWholeFile(path), text);
  // A log whose last line a crash cut short is continued, the broken line cut off.
  const std::string log = dir + "/frames.log";
  { std::ofstream(log, std::ios::binary) << "(1700000000.000000) can0 080#\n(1700000000.0001"; }
  EXPECT_NO_THROW(CandumpWriter::CheckContinuable(log));
  {
    CandumpWriter w(log, "can0", 0.0);
    w.Write(MakeFrame(0x080, {}, 1700000001000000000LL));
    w.Close();
  }
  EXPECT_EQ(sph::testing::ReadWholeFile(log), "(1700000000.000000) can0 080#\n(1700000001.000000) can0 080#\n");
}

}  // namespace
}  // namespace sph::can
