// sph_simulate: write a points file of simulated readings from a stated truth.
#include <iostream>

#include "app_common.hpp"
#include "simulate_cmd.hpp"

int main(int argc, char** argv) {
  CLI::App app;
  sph::apps::SimulateOptions options;
  sph::apps::SetupSimulateApp(app, options);
  app.set_version_flag("--version", "sph_simulate " SPH_VERSION);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return sph::apps::ExitForParseError(app, e);
  }
  return sph::apps::RunSimulate(options, std::cerr);
}
