// sph_cansim's command line: each option bound to its field of the library's
// BusSimulationOptions (which holds the defaults and checks the values), or, for the machine and
// the faults, to a text parsed before the run.
#include <memory>
#include <string>
#include <utility>

#include <CLI/CLI.hpp>

#include "acquire_cmd.hpp"
#include "can_options.hpp"
#include "cansim_cmd.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

namespace r = can::ranges;

// sph_acquired's options: a config file may hold them for the daemon (one file describes both).
std::shared_ptr<CLI::App> AcquiredOptionNames() {
  auto both = std::make_shared<std::pair<AcquireOptions, CLI::App>>();
  SetupAcquireApp(both->second, both->first);
  return std::shared_ptr<CLI::App>(both, &both->second);
}

void AddOutputs(CLI::App& app, CansimOptions& o) {
  can::BusSimulationOptions& b = o.bus;
  app.set_config("--config", "", "Read options from this file (the device options of sph_acquired's config fit)");
  UseStrictConfig(app, "sph_cansim", &o.config_path, AcquiredOptionNames());
  auto* out = app.add_option("-o,--output", b.output_path, "Candump log to write ('-' for stdout)");
  auto* iface = app.add_option("-i,--iface", b.iface, "CAN interface to play onto, in real time")
                    ->check(InterfaceName())
                    ->excludes(out);
  out->excludes(iface);
  app.add_option("--log-iface", b.log_iface, "Interface name written into the log")->check(InterfaceName());
  app.add_option_function<std::string>(
         "--sync-source", [&b](const std::string& s) { b.external_sync = s == "external"; },
         "internal: send SYNC; external (live only): answer received SYNCs")
      ->check(CLI::IsMember({"internal", "external"}))
      ->default_str(b.external_sync ? "external" : "internal");
}

void AddMachine(CLI::App& app, CansimOptions& o) {
  can::DeviceSimConfig& c = o.bus.sim;
  const std::string m = "Machine";
  AddMachineOptions(app, o.machine, m);
  const Eigen::Vector3d& center = c.spec.centers_mm.front();
  app.add_option("--center-mm", o.center_mm, "Sphere centre x,y,z [mm]")
      ->default_str(internal::Format("%g,%g,%g", center.x(), center.y(), center.z()))
      ->group(m);
  app.add_option("--mount-rotation-deg", o.mount_rotation_deg,
                 "rx,ry,rz: the rotation vector (axis times angle) [deg] that takes the sphere's body frame into the "
                 "frame turning with Theta (each " +
                     ranges::kMountRotationDeg.Text() +
                     "); the form below turns with it (give it to sph_acquired for the points file's header)")
      ->group(m);
  AddFormOptions(app, o.form, m);
  AddSeedOption(app, c.spec.seed, "Random seed")->group(m);
  app.add_option("--move-s", c.move_s, "Time to move between pattern points [s]")
      ->check(InRange(r::kStepTimeS))
      ->group(m);
  app.add_option("--stop-s", c.stop_s, "Standstill at each pattern point [s]")->check(InRange(r::kStepTimeS))->group(m);
  app.add_option("--heartbeat-period-s", c.heartbeat_period_s,
                 "Heartbeat period of every node [s] (1017h holds whole ms up to 65535); 0: none")
      ->check(ZeroOrInRange(r::kHeartbeatPeriodS, "none"))
      ->group(m);
  app.add_option("--start-time-s", c.start_time_s, "Log: time of the first SYNC [s since the epoch]")
      ->check(InRange(r::kEpochTimeS))
      ->group(m);
}

void AddFaults(CLI::App& app, CansimOptions& o) {
  can::SimFaults& f = o.bus.sim.faults;
  const std::string g = "Faults";
  app.add_option("--drop-probability", f.drop_probability, "Each PDO is lost with this probability")
      ->check(InRange(r::kProbability))
      ->group(g);
  app.add_option("--short-probability", f.short_probability, "Each PDO loses its last byte (malformed)")
      ->check(InRange(r::kProbability))
      ->group(g);
  app.add_option("--sync-drop-probability", f.sync_drop_probability, "Each SYNC is lost")
      ->check(InRange(r::kProbability))
      ->group(g);
  app.add_option("--probe-out-of-range-probability", f.probe_out_of_range_probability,
                 "The probe sends its over-range code")
      ->check(InRange(r::kProbability))
      ->group(g);
  app.add_option("--jitter-us", f.jitter_us, "Extra PDO delay, uniform in [0, jitter] [us]")
      ->check(InRange(r::kJitterUs))
      ->group(g);
  app.add_option("--error-frame-period-s", f.error_frame_period_s,
                 "An error frame (controller problem) this often [s]; 0: none")
      ->check(ZeroOrInRange(r::kErrorFramePeriodS, "none"))
      ->group(g);
  app.add_option("--bus-off-at-s", f.bus_off_at_s,
                 "A bus-off error frame at this time after the start [s] (repeatable)")
      ->check(InRange(r::kRunTimeS))
      ->group(g);
  app.add_option("--silence", o.silences, "device:from_s:to_s: the device sends nothing then (repeatable)")->group(g);
  app.add_option("--emcy", o.emergencies, "device:at_s:code: an EMCY frame, code in hex (repeatable)")->group(g);
  app.add_option("--fault", o.faults,
                 "reboot:NODE@T: node NODE (a node id, or theta, phi, probe) reboots T s after the start: silent, "
                 "boot-up message, pre-operational until an NMT master starts it; settings-lost:NODE@T: it reboots "
                 "without its stored settings (1017h and 1019h 0, EMCY 0x5000) and cannot be started; preop:NODE@T: it "
                 "enters pre-operational by itself; error:NODE@T: EMCY 0x8100, error register 0x11, pre-operational, "
                 "cleared 1 s later (EMCY 0x0000) (repeatable)")
      ->group(g);
}

void AddNodes(CLI::App& app, can::BusSimulationOptions& b) {
  const std::string n = "CANopen nodes";
  app.add_flag("--boot-operational", b.boot_operational,
               "Live: the devices start operational, as if another master had started them (log mode always does)")
      ->group(n);
  app.add_option("--boot-s", b.sim.boot_s, "Power-on or reset to the boot-up message [s]")
      ->check(InRange(r::kBootS))
      ->group(n);
  app.add_option("--transmission-type", b.sim.transmission_type,
                 "The TPDOs' transmission type after a boot (1: every SYNC; 254: event-driven)")
      ->check(IntegerIn(r::kTransmissionType))
      ->group(n);
  app.add_option("--nodes-sync-counter-max", b.sim.sync_counter_overflow,
                 "The nodes' SYNC counter overflow value (1019h) after a boot; -1: --sync-counter-max. A node whose "
                 "1019h does not fit the SYNC it gets sends EMCY 0x8240 and stays pre-operational")
      ->check(IntegerIn(r::kNodesSyncCounterMax))
      ->group(n);
  app.add_option("--record", b.record_path,
                 "Write what the devices sent for each SYNC: sync_t_s counter theta_deg phi_deg r_mm (- for none)")
      ->group(n);
  app.add_option("--duration-s", b.duration_s, "Live: stop after this long [s]; 0: at the pattern's end")
      ->check(InRange(r::kRunTimeS))
      ->group(n);
}

}  // namespace

void SetupCansimApp(CLI::App& app, CansimOptions& o) {
  app.description(
      "Simulate an SCMS measuring a reference sphere (stop-and-go) as CANopen traffic: SYNC, CiA 406 "
      "encoder TPDOs, the probe TPDO and heartbeats, with faults on demand; into a candump log or onto "
      "a CAN interface.");
  app.option_defaults()->always_capture_default();
  AddOutputs(app, o);
  AddMachine(app, o);
  AddFaults(app, o);
  AddNodes(app, o.bus);
  AddDeviceOptions(app, o.bus.devices, false);
}

}  // namespace sph::apps
