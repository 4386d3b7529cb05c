// sph_calibrate: calibrate an SCMS from points measured on a reference sphere.
#include <iostream>

#include "app_common.hpp"
#include "calibrate_cmd.hpp"

int main(int argc, char** argv) {
  CLI::App app;
  sph::apps::CalibrateOptions options;
  sph::apps::SetupCalibrateApp(app, options);
  app.set_version_flag("--version", "sph_calibrate " SPH_VERSION);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return sph::apps::ExitForParseError(app, e);
  }
  return sph::apps::RunCalibrate(options, std::cout, std::cerr);
}
