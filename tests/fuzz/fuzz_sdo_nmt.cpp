// libFuzzer target: SDO and NMT decoding (sph/can/sdo.hpp, canopen.hpp), the SDO client and
// server state machines and the CANopen master (sph/can/master.hpp) on arbitrary frames and
// time. The first byte chooses the master's options; the rest are frames of 11 bytes each:
//   [0] which id: NMT, SDO answer or request of node 1..3, heartbeat, another id
//   [1] length (mod 9)   [2..9] data   [10] time step [ms]
// Invariants: a transfer ends (done or failed) and then idles, a failed upload returns nothing,
// an upload never holds more than its limit, the server answers on its own id with 8 bytes, the
// master's phase never goes back to starting.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "sph/can/canopen.hpp"
#include "sph/can/master.hpp"
#include "sph/can/sdo.hpp"
#include "sph/can/sdo_server.hpp"

namespace {

using namespace sph::can;

void Check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t options = data[0];
  MasterConfig mc;
  mc.nodes = MasterNodesFor(PipelineConfig{});
  mc.nmt = (options & 1) == 0;
  mc.sdo = (options & 2) == 0;
  mc.nmt_broadcast = (options & 4) != 0;
  mc.reset_communication = mc.nmt && (options & 8) != 0;
  mc.configure_pdo = mc.nmt && (options & 16) != 0;
  mc.trust_config = (options & 32) != 0;
  CanopenMaster master(mc, {[](const CanFrame&) {}, nullptr, nullptr});
  std::int64_t t_ns = 1700000000LL * 1000000000LL;
  master.Begin(t_ns);
  bool was_running = false;

  constexpr std::size_t kMax = 64;
  SdoClient client(1, 500000000, kMax);
  CanFrame req = client.StartUpload({0x1008, 0}, t_ns);
  Check(req.id == 0x601 && req.len == 8);
  ObjectDictionary od;
  od.SetUnsigned({0x1018, 1}, 0x00535048, 4);
  od.Set({0x1008, 0}, std::vector<std::uint8_t>(20, 'x'));
  od.SetUnsigned({0x1800, 2}, 1, 1, ObjectDictionary::Access::kReadWrite);
  SdoServer server(2, &od);

  for (std::size_t pos = 1; pos + 11 <= size; pos += 11) {
    const std::uint8_t* r = data + pos;
    CanFrame f;
    switch (r[0] % 6) {
      case 0:
        f.id = kNmtCobId;
        break;
      case 1:
        f.id = kSdoResponseBase + 1 + (r[0] >> 3) % 3;
        break;
      case 2:
        f.id = kSdoRequestBase + 1 + (r[0] >> 3) % 3;
        break;
      case 3:
        f.id = kHeartbeatBase + 1 + (r[0] >> 3) % 3;
        break;
      case 4:
        f.id = kSdoResponseBase + 1;
        break;
      default:
        f.id = static_cast<std::uint32_t>(r[0]) << 3;
        break;
    }
    f.len = static_cast<std::uint8_t>(r[1] % 9);
    for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = r[2 + i];
    t_ns += std::int64_t{r[10]} * 1000000;
    f.t_ns = t_ns;

    // The decoders: an answer, or a reason.
    std::string why;
    if (!DecodeSdoServer(f, &why)) Check(!why.empty());
    why.clear();
    if (!DecodeSdoClient(f, &why)) Check(!why.empty());
    if (const auto nmt = DecodeNmt(f)) Check(nmt->node_id <= 127 && f.len == 2);

    // The client: one transfer, restarted when it ends.
    SdoClient::Step step = client.OnTime(t_ns);
    if (step.status != SdoClient::Status::kFailed) step = client.OnFrame(f);
    if (step.status == SdoClient::Status::kDone || step.status == SdoClient::Status::kFailed) {
      Check(!client.busy());
      Check(client.data().size() <= kMax);
      if (step.status == SdoClient::Status::kFailed) Check(client.data().empty() && !client.error().text.empty());
      if (step.has_frame) Check(step.frame.id == 0x601 && step.frame.len == 8 && step.frame.data[0] == 0x80);
      client.StartUpload({0x1008, 0}, t_ns);
    } else if (step.status == SdoClient::Status::kContinue) {
      Check(step.has_frame && step.frame.id == 0x601 && step.frame.len == 8);
    }

    // The server of node 2.
    if (const auto answer = server.OnRequest(f)) Check(answer->id == 0x582 && answer->len == 8);
    Check(od.Unsigned({0x1018, 1}) == 0x00535048);  // read-only stays

    // The master.
    master.OnTime(t_ns);
    master.OnFrame(f);
    const CanopenMaster::Phase phase = master.phase();
    if (was_running) Check(phase == CanopenMaster::Phase::kRunning);
    was_running |= phase == CanopenMaster::Phase::kRunning;
    if (phase == CanopenMaster::Phase::kFailed) Check(!master.errors().empty());
    (void)master.HeaderFields();
    (void)master.NextDeadline();
  }
  return 0;
}
