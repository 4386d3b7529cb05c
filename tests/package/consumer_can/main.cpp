// What instrument host software does with the installed sph::can, without a CAN bus: decode a
// CiA 406 position PDO, read an object over SDO from a server in memory, build the NMT start of
// a node, feed the acquisition pipeline one SYNC cycle, and replay a candump log into a points
// file through the acquisition's one call.
#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "sph/can/acquisition.hpp"
#include "sph/can/canopen.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/can/sdo.hpp"
#include "sph/can/sdo_server.hpp"
#include "sph/can/socket.hpp"

int main() {
  using namespace sph::can;
  // SDO: the device name, segmented, from a server of node 5.
  ObjectDictionary od;
  const std::string name = "consumer encoder";
  od.Set({0x1008, 0}, std::vector<std::uint8_t>(name.begin(), name.end()));
  SdoServer server(5, &od);
  SdoClient client(5, 500000000);
  CanFrame f = client.StartUpload({0x1008, 0}, 0);
  SdoClient::Step s;
  for (int i = 0; i < 10; ++i) {
    s = client.OnFrame(*server.OnRequest(f));
    if (s.status != SdoClient::Status::kContinue) break;
    f = s.frame;
  }
  const bool sdo_ok =
      s.status == SdoClient::Status::kDone && std::string(client.data().begin(), client.data().end()) == name;
  // NMT Start remote node 5: 000#0105.
  const bool nmt_ok = ToString(EncodeNmt(NmtCommand::kStart, 5)) == "000#0105";
  // One SYNC cycle through the pipeline: a sample.
  PipelineConfig c;
  int samples = 0;
  AcquisitionPipeline p(c, {[&](const sph::Sample&) { ++samples; }, nullptr, nullptr});
  p.OnFrame(MakeFrame(0x080, {}, 1000000000));
  p.OnFrame(MakeFrame(0x181, {0x00, 0x00, 0x40, 0x00}, 1000100000));  // 2^22 counts: 90 deg
  p.OnFrame(MakeFrame(0x182, {0x00, 0x00, 0x20, 0x00}, 1000200000));
  p.OnFrame(MakeFrame(0x183, {0x40, 0x42, 0x0F, 0x00}, 1000300000));  // 10^6 nm: 1 mm
  p.Finish();
  const bool nodes_ok = MasterNodesFor(c).size() == 3;
  std::string why;
  const bool supported = CanSupported(&why);  // links the socket code; no bus needed
  // Three SYNC cycles of a log replayed into a points file, as sph_acquired --replay does.
  char dir[] = "/tmp/sph_consumer_can_XXXXXX";
  if (::mkdtemp(dir) == nullptr) return 1;
  AcquisitionOptions replay;
  replay.replay_path = std::string(dir) + "/bus.log";
  replay.output_path = std::string(dir) + "/points.txt";
  {
    std::ofstream log(replay.replay_path);
    for (int k = 0; k < 3; ++k) {
      const std::string t = "(1700000000.0" + std::to_string(k) + "0000) can0 ";
      log << t << "080#\n" << t << "181#00004000\n" << t << "182#00002000\n" << t << "183#40420F00\n";
    }
  }
  RunControl control;
  const AcquisitionResult r = ReplayAcquisition(replay, control, {});
  std::remove(replay.output_path.c_str());
  std::remove(replay.replay_path.c_str());
  ::rmdir(dir);
  std::printf("sdo %d, nmt %d, samples %d, nodes %d, replayed rows %llu, CAN_RAW here: %s\n", sdo_ok, nmt_ok, samples,
              nodes_ok, static_cast<unsigned long long>(r.rows_written), supported ? "yes" : why.c_str());
  const bool replayed = r.status == AcquisitionStatus::kOk && r.rows_written == 3;
  return sdo_ok && nmt_ok && samples == 1 && nodes_ok && replayed ? 0 : 1;
}
