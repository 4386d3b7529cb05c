// sph_montecarlo: how the sphere's eccentricity decides what the calibration can identify.
#include <iostream>

#include "app_common.hpp"
#include "montecarlo_cmd.hpp"

int main(int argc, char** argv) {
  return sph::apps::AppMain<sph::apps::MonteCarloAppOptions>(
      argc, argv, "sph_montecarlo", sph::apps::SetupMonteCarloApp,
      [](const sph::apps::MonteCarloAppOptions& o) { return sph::apps::RunMonteCarloApp(o, std::cout, std::cerr); });
}
