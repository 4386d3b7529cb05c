// sph_simulate: write a points file of simulated readings from a stated truth.
#include <iostream>

#include "app_common.hpp"
#include "simulate_cmd.hpp"

int main(int argc, char** argv) {
  return sph::apps::AppMain<sph::apps::SimulateOptions>(
      argc, argv, "sph_simulate", sph::apps::SetupSimulateApp,
      [](const sph::apps::SimulateOptions& o) { return sph::apps::RunSimulate(o, std::cerr); });
}
