// SDO transfers against scripted byte sequences laid out as in CiA 301 §7.2.4.3 (the frames a
// server sends are written here byte by byte, not made by the code under test): expedited and
// segmented uploads with the toggle bit, expedited downloads (and the server's segmented ones),
// aborts, malformed and out-of-order answers, timeouts. Every failure must end in a clear error
// and an abort frame, never a hang, and a failed transfer returns or writes nothing.
#include "sph/can/sdo.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/can/sdo_server.hpp"

namespace sph::can {
namespace {

using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;
using Status = SdoClient::Status;

constexpr std::int64_t kMs = 1000000;
constexpr std::int64_t kT0 = 1700000000LL * 1000000000LL;

CanFrame From(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, std::int64_t t_ns = kT0 + kMs) {
  return MakeFrame(id, bytes, t_ns);
}

std::vector<std::uint8_t> Bytes(const CanFrame& f) { return {f.data.begin(), f.data.begin() + f.len}; }

TEST(SdoFrames, RequestsAreLaidOutAsCiA301Says) {
  // Initiate upload of 0x1018:04 to node 5: ccs 2, index little endian, sub-index.
  const CanFrame up = EncodeUploadRequest(5, {0x1018, 0x04});
  EXPECT_EQ(up.id, 0x605U);
  EXPECT_THAT(Bytes(up), ElementsAre(0x40, 0x18, 0x10, 0x04, 0, 0, 0, 0));
  EXPECT_THAT(Bytes(EncodeUploadSegmentRequest(5, false)), ElementsAre(0x60, 0, 0, 0, 0, 0, 0, 0));
  EXPECT_THAT(Bytes(EncodeUploadSegmentRequest(5, true)), ElementsAre(0x70, 0, 0, 0, 0, 0, 0, 0));
  // Expedited download, size indicated: 4 bytes 0x23, 2 bytes 0x2B, 1 byte 0x2F.
  EXPECT_THAT(Bytes(EncodeDownloadRequest(5, {0x1800, 1}, {0x81, 0x01, 0x00, 0x80})),
              ElementsAre(0x23, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x80));
  EXPECT_THAT(Bytes(EncodeDownloadRequest(5, {0x1017, 0}, {0xE8, 0x03})),
              ElementsAre(0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0));
  EXPECT_THAT(Bytes(EncodeDownloadRequest(5, {0x1800, 2}, {0x01})), ElementsAre(0x2F, 0x00, 0x18, 0x02, 0x01, 0, 0, 0));
  // Abort: ccs 4, the code little endian.
  EXPECT_THAT(Bytes(EncodeAbort(0x605, {0x1018, 4}, kAbortTimeout)),
              ElementsAre(0x80, 0x18, 0x10, 0x04, 0x00, 0x00, 0x04, 0x05));
}

TEST(SdoFrames, ServerMessagesDecode) {
  auto m = DecodeSdoServer(From(0x585, {0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00}));
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->kind, SdoServerMessage::Kind::kInitiateUpload);
  EXPECT_TRUE(m->expedited);
  EXPECT_EQ(m->object, (ObjectAddress{0x1017, 0}));
  EXPECT_THAT(m->data, ElementsAre(0xE8, 0x03));                                       // n = 2: two bytes hold no data
  m = DecodeSdoServer(From(0x585, {0x42, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}));  // e = 1, s = 0
  ASSERT_TRUE(m.has_value());
  EXPECT_THAT(m->data, ElementsAre(0x92, 0x01, 0x02, 0x00));  // unspecified size: all four
  m = DecodeSdoServer(From(0x585, {0x41, 0x08, 0x10, 0x00, 0x1A, 0x00, 0x00, 0x00}));
  ASSERT_TRUE(m.has_value());
  EXPECT_FALSE(m->expedited);
  EXPECT_EQ(m->size, 26U);
  m = DecodeSdoServer(From(0x585, {0x17, 'a', 'b', 'c', 'd', 0, 0, 0}));  // t 1, n 3, c 1
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->kind, SdoServerMessage::Kind::kUploadSegment);
  EXPECT_TRUE(m->toggle);
  EXPECT_TRUE(m->last);
  EXPECT_THAT(m->data, ElementsAre('a', 'b', 'c', 'd'));
  m = DecodeSdoServer(From(0x585, {0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x02, 0x06}));
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->abort_code, kAbortNoObject);
  std::string why;
  EXPECT_FALSE(DecodeSdoServer(From(0x585, {0x43, 0x00, 0x10}), &why).has_value());
  EXPECT_EQ(why, "3 data bytes, an SDO frame has 8");
  EXPECT_FALSE(DecodeSdoServer(From(0x585, {0xC4, 0, 0, 0, 0, 0, 0, 0}), &why).has_value());
  EXPECT_EQ(why, "server command specifier 6 (block transfer) is not supported");
  EXPECT_EQ(DescribeAbort(0x06020000), "0x06020000 (object does not exist in the object dictionary)");
  EXPECT_EQ(DescribeAbort(0x12345678), "0x12345678 (unknown abort code)");
}

TEST(SdoClient, ExpeditedUpload) {
  SdoClient c(5, 500 * kMs);
  const CanFrame req = c.StartUpload({0x1018, 1}, kT0);
  EXPECT_THAT(Bytes(req), ElementsAre(0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0));
  EXPECT_TRUE(c.busy());
  EXPECT_EQ(c.OnFrame(From(0x605, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0})).status, Status::kIgnored);  // our own echo
  EXPECT_EQ(c.OnFrame(From(0x586, {0x43, 0x18, 0x10, 0x01, 1, 2, 3, 4})).status, Status::kIgnored);  // other node
  const SdoClient::Step s = c.OnFrame(From(0x585, {0x43, 0x18, 0x10, 0x01, 0x39, 0x05, 0x00, 0x00}));
  EXPECT_EQ(s.status, Status::kDone);
  EXPECT_FALSE(s.has_frame);
  EXPECT_EQ(LittleEndianValue(c.data()), 0x539U);
  EXPECT_FALSE(c.busy());
  EXPECT_EQ(c.OnFrame(From(0x585, {0x43, 0x18, 0x10, 0x01, 0, 0, 0, 0})).status, Status::kIgnored);  // idle
}

// 0x1008 "sph_cansim theta encoder" (24 bytes): segments of 7, 7, 7 and 3 bytes, toggles 0 1 0 1.
TEST(SdoClient, SegmentedUploadAlternatesTheToggleBit) {
  SdoClient c(1, 500 * kMs);
  c.StartUpload({0x1008, 0}, kT0);
  SdoClient::Step s = c.OnFrame(From(0x581, {0x41, 0x08, 0x10, 0x00, 24, 0, 0, 0}));
  ASSERT_EQ(s.status, Status::kContinue);
  EXPECT_THAT(Bytes(s.frame), ElementsAre(0x60, 0, 0, 0, 0, 0, 0, 0));
  s = c.OnFrame(From(0x581, {0x00, 's', 'p', 'h', '_', 'c', 'a', 'n'}));
  ASSERT_EQ(s.status, Status::kContinue);
  EXPECT_THAT(Bytes(s.frame), ElementsAre(0x70, 0, 0, 0, 0, 0, 0, 0));
  s = c.OnFrame(From(0x581, {0x10, 's', 'i', 'm', ' ', 't', 'h', 'e'}));
  ASSERT_EQ(s.status, Status::kContinue);
  EXPECT_EQ(s.frame.data[0], 0x60);
  s = c.OnFrame(From(0x581, {0x00, 't', 'a', ' ', 'e', 'n', 'c', 'o'}));
  ASSERT_EQ(s.status, Status::kContinue);
  EXPECT_EQ(s.frame.data[0], 0x70);
  s = c.OnFrame(From(0x581, {0x19, 'd', 'e', 'r', 0, 0, 0, 0}));  // t 1, n 4, c 1
  ASSERT_EQ(s.status, Status::kDone);
  EXPECT_EQ(std::string(c.data().begin(), c.data().end()), "sph_cansim theta encoder");
}

TEST(SdoClient, AToggleBitThatDidNotAlternateAborts) {
  SdoClient c(1, 500 * kMs);
  c.StartUpload({0x1008, 0}, kT0);
  c.OnFrame(From(0x581, {0x41, 0x08, 0x10, 0x00, 14, 0, 0, 0}));
  c.OnFrame(From(0x581, {0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}));
  const SdoClient::Step s = c.OnFrame(From(0x581, {0x01, 'h', 'i', 'j', 'k', 'l', 'm', 'n'}));  // toggle 0 again
  ASSERT_EQ(s.status, Status::kFailed);
  ASSERT_TRUE(s.has_frame);
  EXPECT_EQ(s.frame.id, 0x601U);
  EXPECT_THAT(Bytes(s.frame), ElementsAre(0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05));
  EXPECT_EQ(c.error().kind, SdoError::Kind::kProtocol);
  EXPECT_THAT(c.error().text, HasSubstr("toggle bit 0, expected 1"));
  EXPECT_THAT(c.error().text, HasSubstr("0x05030000 (toggle bit not alternated)"));
  EXPECT_TRUE(c.data().empty());  // nothing of a failed upload
  EXPECT_FALSE(c.busy());
}

TEST(SdoClient, TheDevicesAbortEndsTheTransferWithItsCode) {
  SdoClient c(3, 500 * kMs);
  c.StartUpload({0x6001, 0}, kT0);
  const SdoClient::Step s = c.OnFrame(From(0x583, {0x80, 0x01, 0x60, 0x00, 0x00, 0x00, 0x02, 0x06}));
  EXPECT_EQ(s.status, Status::kFailed);
  EXPECT_FALSE(s.has_frame);  // an abort is not answered
  EXPECT_EQ(c.error().kind, SdoError::Kind::kAborted);
  EXPECT_EQ(c.error().code, kAbortNoObject);
  EXPECT_EQ(c.error().text, "the device aborted: 0x06020000 (object does not exist in the object dictionary)");
}

TEST(SdoClient, MalformedAndOutOfOrderAnswersAbort) {
  struct Case {
    std::vector<CanFrame> script;  // server frames after the upload request of 0x1018:02
    std::uint32_t code;
    std::string text;
  };
  const std::vector<Case> cases{
      {{From(0x581, {0x43, 0x18, 0x10})}, kAbortGeneral, "malformed SDO answer 581#431810: 3 data bytes"},
      {{From(0x581, {0x00, 1, 2, 3, 4, 5, 6, 7})}, kAbortCommand, "is not an initiate-upload response"},
      {{From(0x581, {0x60, 0x18, 0x10, 0x02, 0, 0, 0, 0})}, kAbortCommand, "is not an initiate-upload response"},
      {{From(0x581, {0x43, 0x18, 0x10, 0x01, 1, 2, 3, 4})},
       kAbortParameterIncompatible,
       "answer for 0x1018:01 while reading 0x1018:02"},
      {{From(0x581, {0xC1, 0x18, 0x10, 0x02, 0, 0, 0, 0})}, kAbortGeneral, "(block transfer) is not supported"},
      {{From(0x581, {0xE0, 0x18, 0x10, 0x02, 0, 0, 0, 0})}, kAbortGeneral, "server command specifier 7 does not exist"},
      // segmented: more data than announced, less than announced, an initiate where a segment belongs
      {{From(0x581, {0x41, 0x18, 0x10, 0x02, 4, 0, 0, 0}), From(0x581, {0x01, 1, 2, 3, 4, 5, 6, 7})},
       kAbortLengthHigh,
       "more than the announced 4 bytes"},
      {{From(0x581, {0x41, 0x18, 0x10, 0x02, 9, 0, 0, 0}), From(0x581, {0x01, 1, 2, 3, 4, 5, 6, 7})},
       kAbortLengthLow,
       "the segments hold 7 bytes, the device announced 9"},
      {{From(0x581, {0x41, 0x18, 0x10, 0x02, 9, 0, 0, 0}), From(0x581, {0x43, 0x18, 0x10, 0x02, 1, 2, 3, 4})},
       kAbortCommand,
       "is not an upload segment"},
      {{From(0x581, {0x41, 0x18, 0x10, 0x02, 0x00, 0x10, 0x00, 0x00})},
       kAbortOutOfMemory,
       "announces 4096 bytes, more than 1024"},
  };
  for (const Case& k : cases) {
    SdoClient c(1, 500 * kMs);
    c.StartUpload({0x1018, 2}, kT0);
    SdoClient::Step s;
    for (const CanFrame& f : k.script) s = c.OnFrame(f);
    ASSERT_EQ(s.status, Status::kFailed) << k.text;
    ASSERT_TRUE(s.has_frame) << k.text;
    EXPECT_EQ(s.frame.id, 0x601U);
    EXPECT_EQ(s.frame.data[0], 0x80) << k.text;
    EXPECT_EQ(LittleEndianValue({s.frame.data.begin() + 4, s.frame.data.begin() + 8}), k.code) << k.text;
    EXPECT_EQ(c.error().kind, SdoError::Kind::kProtocol);
    EXPECT_THAT(c.error().text, HasSubstr(k.text));
    EXPECT_TRUE(c.data().empty()) << k.text;
    EXPECT_FALSE(c.busy());
  }
}

TEST(SdoClient, NoAnswerTimesOutWithAnAbortAndALateAnswerIsRefused) {
  SdoClient c(2, 500 * kMs);
  c.StartUpload({0x6001, 0}, kT0);
  EXPECT_EQ(c.deadline_ns(), kT0 + 500 * kMs);
  EXPECT_EQ(c.OnTime(kT0 + 499 * kMs).status, Status::kWaiting);
  const SdoClient::Step s = c.OnTime(kT0 + 500 * kMs);
  ASSERT_EQ(s.status, Status::kFailed);
  EXPECT_THAT(Bytes(s.frame), ElementsAre(0x80, 0x01, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05));
  EXPECT_EQ(c.error().kind, SdoError::Kind::kTimeout);
  EXPECT_EQ(c.error().text, "no answer within 500 ms (sent abort 0x05040000 (SDO protocol timed out))");
  EXPECT_EQ(c.OnTime(kT0 + 10000 * kMs).status, Status::kIgnored);  // idle: no second abort
  // The next transfer gets the late answer to the first: another object, refused.
  c.StartUpload({0x6002, 0}, kT0 + 600 * kMs);
  const SdoClient::Step late = c.OnFrame(From(0x582, {0x43, 0x01, 0x60, 0x00, 0, 0, 0, 1}, kT0 + 601 * kMs));
  EXPECT_EQ(late.status, Status::kFailed);
  EXPECT_THAT(c.error().text, HasSubstr("answer for 0x6001:00 while reading 0x6002:00"));
  // Each segment request re-arms the timer from the answer that triggered it.
  c.StartUpload({0x1008, 0}, kT0 + 700 * kMs);
  c.OnFrame(From(0x582, {0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0}, kT0 + 900 * kMs));
  EXPECT_EQ(c.deadline_ns(), kT0 + 1400 * kMs);
  EXPECT_EQ(c.OnTime(kT0 + 1300 * kMs).status, Status::kWaiting);
  EXPECT_EQ(c.OnTime(kT0 + 1400 * kMs).status, Status::kFailed);
}

TEST(SdoClient, ExpeditedDownloadIsConfirmedOrAborted) {
  SdoClient c(4, 500 * kMs);
  const CanFrame req = c.StartDownload({0x1800, 2}, {0x01}, kT0);
  EXPECT_THAT(Bytes(req), ElementsAre(0x2F, 0x00, 0x18, 0x02, 0x01, 0, 0, 0));
  EXPECT_EQ(c.OnFrame(From(0x584, {0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0})).status, Status::kDone);
  c.StartDownload({0x1800, 2}, {0x01}, kT0);
  EXPECT_EQ(c.OnFrame(From(0x584, {0x80, 0x00, 0x18, 0x02, 0x22, 0x00, 0x00, 0x08})).status, Status::kFailed);
  EXPECT_EQ(c.error().code, kAbortDeviceState);
  c.StartDownload({0x1800, 2}, {0x01}, kT0);
  EXPECT_EQ(c.OnFrame(From(0x584, {0x43, 0x00, 0x18, 0x02, 1, 0, 0, 0})).status, Status::kFailed);
  EXPECT_THAT(c.error().text, HasSubstr("not an initiate-download response"));
}

// ----------------------------------------------------------------------------------- server
ObjectDictionary SmallDictionary() {
  ObjectDictionary od;
  od.SetUnsigned({0x1000, 0}, 0x00010196, 4);
  const std::string name = "sph_cansim theta encoder";
  od.Set({0x1008, 0}, std::vector<std::uint8_t>(name.begin(), name.end()));
  od.SetUnsigned({0x1017, 0}, 1000, 2, ObjectDictionary::Access::kReadWrite);
  od.SetUnsigned({0x1018, 1}, 0x00535048, 4);
  return od;
}

TEST(SdoServer, AnswersUploadsAsCiA301LaysThemOut) {
  ObjectDictionary od = SmallDictionary();
  SdoServer server(1, &od);
  auto a = server.OnRequest(From(0x601, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->id, 0x581U);
  EXPECT_THAT(Bytes(*a), ElementsAre(0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00));
  a = server.OnRequest(From(0x601, {0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0));
  a = server.OnRequest(From(0x601, {0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x41, 0x08, 0x10, 0x00, 24, 0, 0, 0));
  a = server.OnRequest(From(0x601, {0x60, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x00, 's', 'p', 'h', '_', 'c', 'a', 'n'));
  a = server.OnRequest(From(0x601, {0x60, 0, 0, 0, 0, 0, 0, 0}));  // toggle not alternated
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05));
  a = server.OnRequest(From(0x601, {0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x02, 0x06));  // no object
  a = server.OnRequest(From(0x601, {0x40, 0x18, 0x10, 0x07, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x18, 0x10, 0x07, 0x11, 0x00, 0x09, 0x06));  // no sub-index
  EXPECT_FALSE(server.OnRequest(From(0x602, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})).has_value());
}

TEST(SdoServer, ARefusedDownloadWritesNothing) {
  ObjectDictionary od = SmallDictionary();
  SdoServer server(1, &od, [](ObjectAddress o, const std::vector<std::uint8_t>& v) {
    return o.index == 0x1017 && LittleEndianValue(v) > 60000 ? kAbortInvalidValue : 0U;
  });
  auto a = server.OnRequest(From(0x601, {0x23, 0x18, 0x10, 0x01, 1, 2, 3, 4}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x18, 0x10, 0x01, 0x02, 0x00, 0x01, 0x06));  // read only
  EXPECT_EQ(od.Unsigned({0x1018, 1}), 0x00535048U);
  a = server.OnRequest(From(0x601, {0x23, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0}));  // 4 bytes into UNSIGNED16
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x12, 0x00, 0x07, 0x06));
  a = server.OnRequest(From(0x601, {0x2B, 0x17, 0x10, 0x00, 0xFF, 0xFF, 0, 0}));  // 65535 ms: refused by the check
  EXPECT_EQ(a->data[0], 0x80);
  EXPECT_EQ(od.Unsigned({0x1017, 0}), 1000U);
  a = server.OnRequest(From(0x601, {0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0}));  // 500 ms
  EXPECT_THAT(Bytes(*a), ElementsAre(0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0));
  EXPECT_EQ(od.Unsigned({0x1017, 0}), 500U);
}

// A normal (segmented) download, CiA 301 §7.2.4.3.3 and .5, as CANopenNode's server answers it:
// initiate 21 (size indicated) answered 60, each segment 0t.. answered 2t with the same toggle bit;
// the value written once the last segment (c = 1) came. Any length, 2 bytes here.
TEST(SdoServer, ANormalDownloadIsTakenSegmentBySegment) {
  ObjectDictionary od = SmallDictionary();
  std::vector<ObjectAddress> written;
  SdoServer server(1, &od, nullptr, [&](ObjectAddress o) { written.push_back(o); });
  auto a = server.OnRequest(From(0x601, {0x21, 0x17, 0x10, 0x00, 0x02, 0x00, 0x00, 0x00}));  // 2 bytes follow
  EXPECT_THAT(Bytes(*a), ElementsAre(0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0));
  EXPECT_EQ(od.Unsigned({0x1017, 0}), 1000U);                            // nothing written yet
  a = server.OnRequest(From(0x601, {0x0B, 0xC8, 0x00, 0, 0, 0, 0, 0}));  // toggle 0, 5 bytes unused, last
  EXPECT_THAT(Bytes(*a), ElementsAre(0x20, 0, 0, 0, 0, 0, 0, 0));
  EXPECT_EQ(od.Unsigned({0x1017, 0}), 200U);
  ASSERT_EQ(written.size(), 1U);
  EXPECT_EQ(written[0], (ObjectAddress{0x1017, 0}));
  // Without a size, in two segments (a 9-byte entry): toggle 0 then 1, answered alike.
  od.Set({0x2100, 1}, std::vector<std::uint8_t>(9, 0), ObjectDictionary::Access::kReadWrite);
  a = server.OnRequest(From(0x601, {0x20, 0x00, 0x21, 0x01, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x60, 0x00, 0x21, 0x01, 0, 0, 0, 0));
  a = server.OnRequest(From(0x601, {0x00, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x20, 0, 0, 0, 0, 0, 0, 0));
  a = server.OnRequest(From(0x601, {0x1B, 8, 9, 0, 0, 0, 0, 0}));  // toggle 1, 2 bytes, last
  EXPECT_THAT(Bytes(*a), ElementsAre(0x30, 0, 0, 0, 0, 0, 0, 0));
  EXPECT_THAT(od.Find({0x2100, 1})->value, ElementsAre(1, 2, 3, 4, 5, 6, 7, 8, 9));
}

TEST(SdoServer, ANormalDownloadIsRefusedAsCANopenNodeRefusesIt) {
  ObjectDictionary od = SmallDictionary();
  SdoServer server(1, &od);
  // No such object, no such sub-index, a read-only entry: refused at the initiate.
  auto a = server.OnRequest(From(0x601, {0x21, 0x22, 0x22, 0x00, 0x02, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x22, 0x22, 0x00, 0x00, 0x00, 0x02, 0x06));
  a = server.OnRequest(From(0x601, {0x21, 0x18, 0x10, 0x09, 0x04, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x18, 0x10, 0x09, 0x11, 0x00, 0x09, 0x06));
  a = server.OnRequest(From(0x601, {0x21, 0x18, 0x10, 0x01, 0x04, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x18, 0x10, 0x01, 0x02, 0x00, 0x01, 0x06));
  // A size that is not the entry's: too high, too low.
  a = server.OnRequest(From(0x601, {0x21, 0x17, 0x10, 0x00, 0x05, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x12, 0x00, 0x07, 0x06));
  a = server.OnRequest(From(0x601, {0x21, 0x17, 0x10, 0x00, 0x01, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x13, 0x00, 0x07, 0x06));
  // Segments: a toggle bit that did not alternate, more bytes than the entry holds.
  server.OnRequest(From(0x601, {0x20, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  a = server.OnRequest(From(0x601, {0x10, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05));
  server.OnRequest(From(0x601, {0x20, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  a = server.OnRequest(From(0x601, {0x09, 1, 2, 3, 0, 0, 0, 0}));  // 3 bytes into UNSIGNED16
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x12, 0x00, 0x07, 0x06));
  EXPECT_EQ(od.Unsigned({0x1017, 0}), 1000U);
  // While a transfer is in progress only its next segment is taken; a client's abort ends it.
  server.OnRequest(From(0x601, {0x21, 0x17, 0x10, 0x00, 0x02, 0, 0, 0}));
  a = server.OnRequest(From(0x601, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x01, 0x00, 0x04, 0x05));
  a = server.OnRequest(From(0x601, {0x0B, 0xC8, 0x00, 0, 0, 0, 0, 0}));  // no transfer any more
  EXPECT_THAT(Bytes(*a), ElementsAre(0x80, 0x17, 0x10, 0x00, 0x01, 0x00, 0x04, 0x05));
  server.OnRequest(From(0x601, {0x21, 0x17, 0x10, 0x00, 0x02, 0, 0, 0}));
  EXPECT_FALSE(server.OnRequest(From(0x601, {0x80, 0x17, 0x10, 0x00, 0, 0, 0x04, 0x05})).has_value());
  a = server.OnRequest(From(0x601, {0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_THAT(Bytes(*a), ElementsAre(0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0));
}

TEST(SdoServer, ClientAndServerAgreeOnEveryLength) {
  for (std::size_t n = 1; n <= 40; ++n) {
    ObjectDictionary od;
    std::vector<std::uint8_t> value(n);
    for (std::size_t i = 0; i < n; ++i) value[i] = static_cast<std::uint8_t>(37 * i + n);
    od.Set({0x2000, 3}, value);
    SdoServer server(9, &od);
    SdoClient client(9, 500 * kMs);
    CanFrame f = client.StartUpload({0x2000, 3}, kT0);
    SdoClient::Step s;
    for (int round = 0; round < 20; ++round) {
      const auto answer = server.OnRequest(f);
      ASSERT_TRUE(answer.has_value());
      s = client.OnFrame(*answer);
      if (s.status != Status::kContinue) break;
      f = s.frame;
    }
    ASSERT_EQ(s.status, Status::kDone) << n;
    EXPECT_THAT(client.data(), ElementsAreArray(value)) << n;
  }
}

}  // namespace
}  // namespace sph::can
