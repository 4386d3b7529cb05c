// sph_calibrate: calibrate an SCMS from points measured on a reference sphere.
#include <iostream>

#include "app_common.hpp"
#include "calibrate_cmd.hpp"

int main(int argc, char** argv) {
  return sph::apps::AppMain<sph::apps::CalibrateOptions>(
      argc, argv, "sph_calibrate", sph::apps::SetupCalibrateApp,
      [](const sph::apps::CalibrateOptions& o) { return sph::apps::RunCalibrate(o, std::cout, std::cerr); });
}
