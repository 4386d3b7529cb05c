// sph_acquired: CANopen encoders and probe over SocketCAN (or a candump log) into points files.
#include <iostream>

#include "acquire_cmd.hpp"
#include "app_common.hpp"

int main(int argc, char** argv) {
  return sph::apps::AppMain<sph::apps::AcquireOptions>(argc, argv, "sph_acquired", sph::apps::SetupAcquireApp,
                                                       [](const sph::apps::AcquireOptions& o) {
                                                         sph::apps::InstallSignalHandlers();
                                                         return sph::apps::RunAcquire(o, std::cerr);
                                                       });
}
