// sph_cansim: a simulated SCMS as CANopen traffic, into a candump log or onto a CAN interface.
#include <iostream>

#include "acquire_cmd.hpp"
#include "app_common.hpp"
#include "cansim_cmd.hpp"

int main(int argc, char** argv) {
  return sph::apps::AppMain<sph::apps::CansimOptions>(argc, argv, "sph_cansim", sph::apps::SetupCansimApp,
                                                      [](const sph::apps::CansimOptions& o) {
                                                        sph::apps::InstallSignalHandlers();
                                                        return sph::apps::RunCansim(o, std::cerr);
                                                      });
}
