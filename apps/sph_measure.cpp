// sph_measure: measure a sphere with a calibration (or from x y z points): least-squares sphere,
// least-squares and minimum-zone sphericity, their uncertainty from the calibration, form-error map.
#include <iostream>

#include "app_common.hpp"
#include "measure_cmd.hpp"

int main(int argc, char** argv) {
  return sph::apps::AppMain<sph::apps::MeasureOptions>(
      argc, argv, "sph_measure", sph::apps::SetupMeasureApp,
      [](const sph::apps::MeasureOptions& o) { return sph::apps::RunMeasure(o, std::cout, std::cerr); });
}
