// One run of the simulated bus (internal): what SimulateBusLog and SimulateBusLive share.
#ifndef SPH_CAN_BUS_SIMULATION_INTERNAL_HPP_
#define SPH_CAN_BUS_SIMULATION_INTERNAL_HPP_

#include <optional>
#include <string>

#include "sph/can/bus_simulation.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/io/output_files.hpp"

namespace sph::can {

struct BusRun {
  BusRun(const BusSimulationOptions& options, RunControl& run_control, const BusSimulationHooks& run_hooks)
      : o(options), control(run_control), hooks(run_hooks) {}

  /// The checks, the paths, the simulator (`live`: powered on now); reports the cycles. The
  /// result so far (kBadInput on a failure).
  BusSimulationResult Begin(bool live);
  /// After the log or the play: the faults injected reported, the record staged, every output
  /// put in place.
  BusSimulationResult End();
  /// Reports `error` and returns the result with it.
  BusSimulationResult Fail(BusSimulationStatus status, const std::string& error);
  void Report(LogLevel level, const std::string& text) const;

  const BusSimulationOptions& o;
  RunControl& control;
  const BusSimulationHooks& hooks;
  DeviceSimConfig config;
  std::optional<DeviceSimulator> sim;
  OutputFiles files;  ///< removes what it staged unless committed
  BusSimulationResult result;
};

}  // namespace sph::can

#endif  // SPH_CAN_BUS_SIMULATION_INTERNAL_HPP_
