// sph_acquired's command line: each option bound to its field of the library's
// AcquisitionOptions, which holds the defaults and checks the values (the texts of a few options
// are parsed here into the library's types).
#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "acquire_cmd.hpp"
#include "app_common.hpp"
#include "can_options.hpp"
#include "sph/can/sdo.hpp"
#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

namespace r = can::ranges;

void AddInputsAndOutputs(CLI::App& app, AcquireOptions& o) {
  can::AcquisitionOptions& a = o.acq;
  app.set_config("--config", "", "Read options from this file (TOML/INI, 'name = value'; see data/sph_acquired.conf)");
  UseStrictConfig(app, "sph_acquired", &o.config_path);
  auto* iface = app.add_option("-i,--iface", a.iface, "CAN interface to acquire from (live)")->check(InterfaceName());
  auto* replay =
      app.add_option("--replay", a.replay_path, "Candump log to replay instead of a live interface")->excludes(iface);
  iface->excludes(replay);
  app.add_option("--replay-iface", a.replay_iface,
                 "Replay: the interface whose frames are replayed (a log of 'candump -l any' holds several); "
                 "default: the log's only one")
      ->check(InterfaceName());
  app.add_option("-o,--output", a.output_path, "Points file (sph-points 1); appended, never overwritten")->required();
  app.add_option("--can-log", a.can_log_path, "Also append every frame to this candump log");
  app.add_option_function<std::string>(
         "--mode", [&a](const std::string& m) { a.mode = m == "points" ? can::Mode::kPoints : can::Mode::kStream; },
         "stream: a row per SYNC cycle; points: one averaged row per standstill")
      ->check(CLI::IsMember({"stream", "points"}))
      ->default_str(can::ToString(a.mode));
}

// The points file's header and rows: the setup, R0, d, the mount rotation, another sphere, fsync.
void AddPointsFile(CLI::App& app, can::AcquisitionOptions& a) {
  app.add_option("--setup", a.setup, "Sphere placement id written in the setup column");
  app.add_option("--sphere-radius-mm", a.sphere_radius_mm, "Header: reference sphere radius R0 [mm]")
      ->check(InRange(r::kSphereRadiusMm));
  app.add_option("--probe-offset-mm", a.probe_offset_mm, "Header: nominal probe zero distance d [mm]")
      ->check(InRange(r::kProbeOffsetMm));
  app.add_option_function<std::string>(
      "--mount-rotation-deg",
      [&a](const std::string& t) {
        if (t == "unknown") {
          a.mount_rotation = MountRotation::Unknown();
        } else if (!t.empty()) {
          a.mount_rotation = MountRotation::Known(
              ParseRotationDeg(t, "--mount-rotation-deg " + internal::Quoted(t),
                               "rx,ry,rz (a rotation vector in deg, axis times angle) or unknown"));
        }
      },
      "Header: the sphere's orientation on its mount in this setup, rx,ry,rz (rotation vector, axis times angle "
      "[deg], each " +
          ranges::kMountRotationDeg.Text() + ") or unknown (remounted at an unknown orientation)");
  app.add_option("--other-sphere-radius-mm", a.other_sphere_radius_mm,
                 "Header: this setup measures another sphere than the reference one, of this radius [mm] "
                 "(sphere_radius_mm@SETUP; it tells a probe's gain from its incidence error)")
      ->check(InRange(r::kSphereRadiusMm));
  app.add_option("--fsync-interval-s", a.fsync_interval_s,
                 "fsync the output at most this long after a record [s]; 0: every record; -1: only at the end")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            bool ok = false;
            try {
              const double v = ParseNumber(text, "", "");
              ok = v == -1.0 || r::kFsyncIntervalS.Contains(v);
            } catch (const Error&) {  // not a finite number: refused with the range
            }
            return ok ? "" : "must be -1 (only at the end) or " + r::kFsyncIntervalS.Refusal(text).substr(8);
          },
          "-1 or " + r::kFsyncIntervalS.Text()));
}

// The bus, the stops of points mode, how long and how fast, the log.
void AddRun(CLI::App& app, AcquireOptions& o) {
  can::AcquisitionOptions& a = o.acq;
  app.add_option_function<std::string>(
         "--sync-mode",
         [&a](const std::string& m) { a.sync_mode = m == "follow" ? can::SyncMode::kFollow : can::SyncMode::kProduce; },
         "produce: send SYNC every --sync-period-ms; follow: an external producer")
      ->check(CLI::IsMember({"produce", "follow"}))
      ->default_str(a.sync_mode == can::SyncMode::kFollow ? "follow" : "produce");
  app.add_option("--heartbeat-timeout-s", a.heartbeat_timeout_s,
                 "A node without heartbeat this long is lost [s]; 0: off; -1: three of the longest producer heartbeat "
                 "time the master found or set (off with --no-sdo)")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            bool ok = false;
            try {
              const double v = ParseNumber(text, "", "");
              ok = v == -1.0 || r::kTimeoutS.Contains(v);
            } catch (const Error&) {  // not a finite number: refused with the range
            }
            return ok ? ""
                      : "must be -1 (three of the nodes' heartbeat times) or " + r::kTimeoutS.Refusal(text).substr(8);
          },
          "-1 or " + r::kTimeoutS.Text()));
  app.add_option("--bitrate-kbit-s", a.bitrate_kbit_s,
                 "The bus's bitrate [kbit/s]: a SYNC period whose frames the bus cannot carry is refused, over half "
                 "of it warned; without --sync-period-ms the shortest of 1, 2, 5, 10, ... ms under half is chosen; "
                 "0: the interface's, where the kernel reports it")
      ->check(ZeroOrInRange(r::kBitrateKbitS, "the interface's"));
  app.add_option("--standstill-tol-deg", a.standstill.tolerance_deg,
                 "Points mode: both axes within this of the stop [deg]")
      ->check(InRange(r::kStandstillTolDeg));
  app.add_option("--dwell-s", a.standstill.dwell_s, "Points mode: still this long before averaging starts [s]")
      ->check(InRange(r::kTimeoutS));
  app.add_option("--average-s", a.standstill.average_s,
                 "Points mode: averaging time per stop [s]; 0: until the axes move")
      ->check(InRange(r::kTimeoutS));
  app.add_option("--min-samples", a.standstill.min_samples, "Points mode: fewer averaged samples: no point")
      ->check(IntegerIn(r::kMinSamples));
  app.add_option("--duration-s", a.duration_s, "Live: stop after this long [s]; 0: until SIGTERM/SIGINT")
      ->check(InRange(r::kRunTimeS));
  app.add_option("--replay-speed", a.replay_speed, "Replay: 1 = the log's own pace; 0: as fast as possible")
      ->check(InRange(r::kReplaySpeed));
  app.add_option("--reopen-interval-s", a.reopen_interval_s,
                 "Live: check this often whether a lost interface is back [s]")
      ->check(InRange(r::kReopenIntervalS));
  app.add_option("--rcvbuf-bytes", a.rcvbuf_bytes, "Live: socket receive buffer (SO_RCVBUF); 0: kernel default")
      ->check(InRange(r::kRcvbufBytes));
  app.add_option("--log-level", o.log_level, "error, warning, info or debug")
      ->check(CLI::IsMember({"error", "warning", "info", "debug"}));
  // CLI11 sums a flag's values with std::stoll, which throws on a count beyond 64 bits ("stoll"),
  // and takes any integer: each value is checked first (validators run before the sum).
  app.add_flag("-v,--verbose", o.verbose, "One log level more (repeatable)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            std::int64_t count = 0;
            try {
              count = CLI::detail::to_flag_value(value);
            } catch (const std::exception&) {
              count = -2;
            }
            return count >= -1 && count <= 3 ? "" : "'" + value + "' is not a count of 0 to 3 levels";
          },
          "COUNT"));
}

void AddMaster(CLI::App& app, can::AcquisitionOptions& a) {
  const std::string m = "CANopen master";
  // Conflicts are found by the library: CLI11 counts a flag set false in a config file as given.
  app.add_flag("--no-nmt", a.no_nmt, "Send no NMT command: another master starts the devices")->group(m);
  app.add_flag("--nmt-broadcast", a.nmt_broadcast, "Start all nodes with one NMT command to node 0")->group(m);
  app.add_flag("--nmt-reset-comm", a.nmt_reset_comm,
               "First NMT Reset communication, then wait for each node's boot-up message")
      ->group(m);
  app.add_flag("--nmt-stop-at-exit", a.nmt_stop_at_exit, "At the end, NMT Stop remote node")->group(m);
  app.add_flag("--nmt-preop-at-exit", a.nmt_preop_at_exit, "At the end, NMT Enter pre-operational")->group(m);
  app.add_flag("--no-sdo", a.no_sdo, "Do not identify or check the devices over SDO (no identity in the header)")
      ->group(m);
  app.add_flag("--trust-config", a.trust_config,
               "Acquire even when a device's resolution or TPDO settings differ from the configuration (warnings)")
      ->group(m);
  app.add_flag("--configure-pdo", a.configure_pdo,
               "Write each TPDO's COB-ID, transmission type 1 and mapping and the SYNC counter overflow value 1019h "
               "(pre-operational), verify by reading back")
      ->group(m);
  app.add_option("--node-heartbeat-ms", a.node_heartbeat_ms,
                 "Producer heartbeat time written into a node that sends none (1017h = 0), so that its heartbeat "
                 "confirms that it is operational [ms]; 0: none written (such a node is refused unless "
                 "--trust-config)")
      ->check(IntegerIn(r::kNodeHeartbeatMs))
      ->group(m);
  app.add_option("--sdo-timeout-ms", a.sdo_timeout_ms, "An SDO answer later than this fails the transfer [ms]")
      ->check(InRange(r::kSdoTimeoutMs))
      ->group(m);
  app.add_option("--boot-timeout-s", a.boot_timeout_s, "Wait this long for boot-ups after Reset communication [s]")
      ->check(InRange(r::kBootTimeoutS))
      ->group(m);
  app.add_option("--node-return-timeout-s", a.node_return_timeout_s,
                 "A node that left operational mid-run (rebooted, or its heartbeat says another state) is started "
                 "again; not operational within this, the run ends (exit 6) [s]")
      ->check(InRange(r::kNodeReturnTimeoutS))
      ->group(m);
  app.add_option_function<std::string>(
         "--probe-pdo-object",
         [&a](const std::string& t) {
           a.probe_pdo_object.reset();
           if (!t.empty()) a.probe_pdo_object = can::ParseObjectAddress(t, "--probe-pdo-object '" + t + "'");
         },
         "Probe: the object (INDEX:SUB, e.g. 0x2000:00) its TPDO maps at --probe-offset-byte; checked, and "
         "written with --configure-pdo")
      ->group(m);
}

}  // namespace

void SetupAcquireApp(CLI::App& app, AcquireOptions& o) {
  app.description(
      "Acquire SCMS samples from CANopen encoders and a probe over SocketCAN (or replay a candump log) "
      "into an sph-points 1 file, appending record by record. As CANopen master it starts the devices "
      "(NMT), identifies and checks them (SDO) and restarts a node that reboots.");
  app.option_defaults()->always_capture_default();
  AddInputsAndOutputs(app, o);
  AddPointsFile(app, o.acq);
  AddRun(app, o);
  AddMaster(app, o.acq);
  AddDeviceOptions(app, o.acq.devices, true);
}

}  // namespace sph::apps
