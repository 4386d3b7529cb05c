#include "cansim_cmd.hpp"

#include "acquire_cmd.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

// The machine of the options: the spec of sph_simulate's options, the seed, the centre, the
// sphere's turn on its mount and its form.
SimulationSpec MachineSpec(const CansimOptions& o) {
  SimulationSpec spec = ToSimulationSpec(o.machine);
  spec.seed = o.bus.sim.spec.seed;
  if (!o.center_mm.empty()) spec.centers_mm = {ParseVector3(o.center_mm, "--center-mm")};
  if (!o.mount_rotation_deg.empty()) {
    spec.mount_rotations_deg[0] =
        ParseRotationDeg(o.mount_rotation_deg, "--mount-rotation-deg " + internal::Quoted(o.mount_rotation_deg),
                         "rx,ry,rz (a rotation vector in deg, axis times angle)");
  }
  AddForm(o.form, spec.sphere_radius_mm, spec.effects);
  return spec;
}

int ExitCodeOf(const can::BusSimulationResult& r) {
  switch (r.status) {
    case can::BusSimulationStatus::kOk:
      return kExitOk;
    case can::BusSimulationStatus::kBadInput:
      return kExitBadInput;
    case can::BusSimulationStatus::kOutputError:
      return kExitOutputError;
    case can::BusSimulationStatus::kInterfaceError:
      return kExitInterfaceError;
    case can::BusSimulationStatus::kStopped:
      return 128 + r.stopped_by;
  }
  return kExitBadInput;
}

}  // namespace

can::BusSimulationOptions BusOptions(const CansimOptions& o) {
  can::BusSimulationOptions bus = o.bus;
  bus.sim.spec = MachineSpec(o);
  can::SimFaults& f = bus.sim.faults;
  for (const std::string& s : o.silences) f.silences.push_back(can::ParseSilence(s));
  for (const std::string& s : o.emergencies) f.emergencies.push_back(can::ParseEmcy(s));
  for (const std::string& s : o.faults) f.reboots.push_back(can::ParseFault(s, bus.devices));
  if (!o.config_path.empty()) bus.option_files.emplace_back("--config", o.config_path);
  if (!o.machine.angles_path.empty()) bus.option_files.emplace_back("--angles", o.machine.angles_path);
  return bus;
}

int RunCansim(const CansimOptions& o, std::ostream& err) {
  const auto log = [&err](can::LogLevel level, const std::string& text) {
    err << "sph_cansim: " << (level == can::LogLevel::kError ? "error: " : "") << text << "\n";
  };
  can::BusSimulationOptions bus;
  try {
    bus = BusOptions(o);
  } catch (const std::exception& e) {
    log(can::LogLevel::kError, e.what());
    return kExitBadInput;
  }
  const auto simulate = bus.iface.empty() ? can::SimulateBusLog : can::SimulateBusLive;
  return ExitCodeOf(simulate(bus, ProcessControl(), {log}));
}

}  // namespace sph::apps
