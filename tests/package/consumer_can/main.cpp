// What instrument host software does with the installed sph::can, without a CAN bus: decode a
// CiA 406 position PDO, read an object over SDO from a server in memory, build the NMT start of
// a node and feed the acquisition pipeline one SYNC cycle.
#include <cstdio>
#include <string>

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
  std::printf("sdo %d, nmt %d, samples %d, nodes %d, CAN_RAW here: %s\n", sdo_ok, nmt_ok, samples, nodes_ok,
              supported ? "yes" : why.c_str());
  return sdo_ok && nmt_ok && samples == 1 && nodes_ok ? 0 : 1;
}
