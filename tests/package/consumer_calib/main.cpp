// Calibrates simulated data through the installed library.
#include <cstdio>

#include "sph/calib/calibrator.hpp"
#include "sph/simulation/simulate.hpp"

int main() {
  sph::SimulationSpec spec;
  sph::CalibrationOptions options;
  options.sphere_radius_mm = spec.sphere_radius_mm;
  options.probe_offset_mm = spec.probe_offset_mm;
  const sph::CalibrationResult r = sph::Calibrate(sph::Simulate(spec), options);
  std::printf("rms %.4f um, usable %d\n", r.rms_um, r.Usable() ? 1 : 0);
  return r.Usable() ? 0 : 1;
}
