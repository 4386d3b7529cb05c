// sph_cansim: a simulated SCMS as CANopen traffic, into a candump log or onto a CAN interface. The
// simulation is the library's (sph/can/bus_simulation.hpp); this declares its options, parses the
// texts of the machine and the faults, and prints what it tells.
#ifndef SPH_APPS_CANSIM_CMD_HPP_
#define SPH_APPS_CANSIM_CMD_HPP_

#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "sph/can/bus_simulation.hpp"

namespace sph::apps {

struct CansimOptions {
  can::BusSimulationOptions bus;         ///< every option but those below, bound to the library's fields
  std::string config_path;               ///< the --config file read (an input: never an output)
  MachineOptions machine;                ///< truth, sphere, pattern, noise (as sph_simulate)
  std::string center_mm;                 ///< "x,y,z" [mm]; empty: the simulation's default centre
  std::string mount_rotation_deg;        ///< "rx,ry,rz": the sphere's body frame on its mount (deg); empty: none
  FormOptions form;                      ///< the sphere's form error on its body frame
  std::vector<std::string> silences;     ///< "device:from_s:to_s"
  std::vector<std::string> emergencies;  ///< "device:at_s:code"
  std::vector<std::string> faults;       ///< "reboot:NODE@T", "settings-lost:NODE@T"
};

void SetupCansimApp(CLI::App& app, CansimOptions& options);

/// The library's options of `options`: the machine's spec and the faults parsed from their texts.
/// Throws sph::Error naming the option and its value.
can::BusSimulationOptions BusOptions(const CansimOptions& options);

/// Writes the log or plays onto the interface (can::SimulateBusLog, can::SimulateBusLive) with
/// ProcessControl() (acquire_cmd.hpp); what it tells goes to `err` ("sph_cansim: ..."). Returns
/// kExitOk, kExitBadInput, kExitOutputError, kExitInterfaceError, or 128 + the signal's number
/// when a stop signal cut a log short (it is removed).
int RunCansim(const CansimOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_CANSIM_CMD_HPP_
