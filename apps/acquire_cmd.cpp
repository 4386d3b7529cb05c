#include "acquire_cmd.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>

#include <CLI/CLI.hpp>

#include "acquire_internal.hpp"
#include "app_common.hpp"

namespace sph::apps {
namespace {

SignalFlags g_signals;

extern "C" void OnStopSignal(int sig) { g_signals.stop = sig; }
extern "C" void OnSummarySignal(int) { g_signals.summary = 1; }

constexpr ValidRange kFsyncIntervalS{0.0, 86400.0, "s"};
constexpr ValidRange kTimeoutS{0.0, 86400.0, "s"};
constexpr ValidRange kStandstillTolDeg{0.0, 360.0, "deg", true};

can::LogLevel ParseLevel(const std::string& text, int verbose) {
  int level = text == "error" ? 0 : text == "warning" ? 1 : text == "info" ? 2 : 3;
  level += verbose;
  return static_cast<can::LogLevel>(level > 3 ? 3 : level);
}

}  // namespace

SignalFlags& ProcessSignals() { return g_signals; }

void InstallSignalHandlers() {
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking call returns EINTR and the loop sees the flag
  sa.sa_handler = OnStopSignal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  sa.sa_handler = OnSummarySignal;
  sigaction(SIGUSR1, &sa, nullptr);
}

void Logger::operator()(can::LogLevel level, const std::string& text) const {
  if (Enabled(level)) out_ << "sph_acquired: " << can::ToString(level) << ": " << text << "\n" << std::flush;
}

void SetupAcquireApp(CLI::App& app, AcquireOptions& o) {
  app.description(
      "Acquire SCMS samples from CANopen encoders and a probe over SocketCAN (or replay a candump log) "
      "into an sph-points 1 file, appending record by record. As CANopen master it starts the devices "
      "(NMT), identifies and checks them (SDO) and restarts a node that reboots.");
  app.option_defaults()->always_capture_default();
  app.set_config("--config", "", "Read options from this file (TOML/INI, 'name = value'; see data/sph_acquired.conf)");
  UseStrictConfig(app, "sph_acquired", &o.config_path);
  auto* iface = app.add_option("-i,--iface", o.iface, "CAN interface to acquire from (live)")->check(InterfaceName());
  auto* replay =
      app.add_option("--replay", o.replay_path, "Candump log to replay instead of a live interface")->excludes(iface);
  iface->excludes(replay);
  app.add_option("--replay-iface", o.replay_iface,
                 "Replay: the interface whose frames are replayed (a log of 'candump -l any' holds several); "
                 "default: the log's only one")
      ->check(InterfaceName());
  app.add_option("-o,--output", o.output_path, "Points file (sph-points 1); appended, never overwritten")->required();
  app.add_option("--can-log", o.can_log_path, "Also append every frame to this candump log");
  app.add_option("--mode", o.mode, "stream: a row per SYNC cycle; points: one averaged row per standstill")
      ->check(CLI::IsMember({"stream", "points"}));
  app.add_option("--setup", o.setup, "Sphere placement id written in the setup column");
  app.add_option("--sphere-radius-mm", o.sphere_radius_mm, "Header: reference sphere radius R0 [mm]")
      ->check(InRange(ranges::kSphereRadiusMm));
  app.add_option("--probe-offset-mm", o.probe_offset_mm, "Header: nominal probe zero distance d [mm]")
      ->check(InRange(ranges::kProbeOffsetMm));
  app.add_option("--mount-rotation-deg", o.mount_rotation_deg,
                 "Header: the sphere's orientation on its mount in this setup, rx,ry,rz (rotation vector, axis times "
                 "angle [deg], each " +
                     ranges::kMountRotationDeg.Text() + ") or unknown (remounted at an unknown orientation)");
  app.add_option("--other-sphere-radius-mm", o.other_sphere_radius_mm,
                 "Header: this setup measures another sphere than the reference one, of this radius [mm] "
                 "(sphere_radius_mm@SETUP; it tells a probe's gain from its incidence error)")
      ->check(InRange(ranges::kSphereRadiusMm));
  app.add_option("--fsync-interval-s", o.fsync_interval_s,
                 "fsync the output at most this long after a record [s]; 0: every record; -1: only at the end")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            const bool ok = end != text.c_str() && *end == '\0' && (v == -1.0 || kFsyncIntervalS.Contains(v));
            return ok ? "" : "must be -1 (only at the end) or " + kFsyncIntervalS.Refusal(text).substr(8);
          },
          "-1 or " + kFsyncIntervalS.Text()));
  app.add_option("--sync-mode", o.sync_mode, "produce: send SYNC every --sync-period-ms; follow: an external producer")
      ->check(CLI::IsMember({"produce", "follow"}));
  app.add_option("--heartbeat-timeout-s", o.heartbeat_timeout_s, "A node without heartbeat this long is lost; 0: off")
      ->check(InRange(kTimeoutS));
  app.add_option("--standstill-tol-deg", o.standstill_tol_deg, "Points mode: both axes within this of the stop [deg]")
      ->check(InRange(kStandstillTolDeg));
  app.add_option("--dwell-s", o.dwell_s, "Points mode: still this long before averaging starts [s]")
      ->check(InRange(kTimeoutS));
  app.add_option("--average-s", o.average_s, "Points mode: averaging time per stop [s]; 0: until the axes move")
      ->check(InRange(kTimeoutS));
  app.add_option("--min-samples", o.min_samples, "Points mode: fewer averaged samples: no point")
      ->check(CLI::Range(1, 100000000));
  app.add_option("--duration-s", o.duration_s, "Live: stop after this long [s]; 0: until SIGTERM/SIGINT")
      ->check(InRange(ranges::kRunTimeS));
  app.add_option("--replay-speed", o.replay_speed, "Replay: 1 = the log's own pace; 0: as fast as possible")
      ->check(InRange({0.0, 1e6, "times the log's pace"}));
  app.add_option("--reopen-interval-s", o.reopen_interval_s,
                 "Live: check this often whether a lost interface is back [s]")
      ->check(InRange({0.0, 3600.0, "s", true}));
  app.add_option("--rcvbuf-bytes", o.rcvbuf_bytes, "Live: socket receive buffer (SO_RCVBUF); 0: kernel default")
      ->check(InRange({0.0, 1073741824.0, "bytes"}));
  app.add_option("--log-level", o.log_level, "error, warning, info or debug")
      ->check(CLI::IsMember({"error", "warning", "info", "debug"}));
  app.add_flag("-v,--verbose", o.verbose, "One log level more (repeatable)");
  const std::string m = "CANopen master";
  // Conflicts are found by MakeMasterConfig: CLI11 counts a flag set false in a config file as given.
  app.add_flag("--no-nmt", o.no_nmt, "Send no NMT command: another master starts the devices")->group(m);
  app.add_flag("--nmt-broadcast", o.nmt_broadcast, "Start all nodes with one NMT command to node 0")->group(m);
  app.add_flag("--nmt-reset-comm", o.nmt_reset_comm,
               "First NMT Reset communication, then wait for each node's boot-up message")
      ->group(m);
  app.add_flag("--nmt-stop-at-exit", o.nmt_stop_at_exit, "At the end, NMT Stop remote node")->group(m);
  app.add_flag("--nmt-preop-at-exit", o.nmt_preop_at_exit, "At the end, NMT Enter pre-operational")->group(m);
  app.add_flag("--no-sdo", o.no_sdo, "Do not identify or check the devices over SDO (no identity in the header)")
      ->group(m);
  app.add_flag("--trust-config", o.trust_config,
               "Acquire even when a device's resolution or TPDO settings differ from the configuration (warnings)")
      ->group(m);
  app.add_flag("--configure-pdo", o.configure_pdo,
               "Write each TPDO's COB-ID, transmission type 1 and mapping and the SYNC counter overflow value 1019h "
               "(pre-operational), verify by reading back")
      ->group(m);
  app.add_option("--node-heartbeat-ms", o.node_heartbeat_ms,
                 "Producer heartbeat time written into a node that sends none (1017h = 0), so that its heartbeat "
                 "confirms that it is operational [ms]; 0: none written (such a node is refused unless "
                 "--trust-config)")
      ->check(CLI::Range(0, 65535))
      ->group(m);
  app.add_option("--sdo-timeout-ms", o.sdo_timeout_ms, "An SDO answer later than this fails the transfer [ms]")
      ->check(InRange({1.0, 60000.0, "ms"}))
      ->group(m);
  app.add_option("--boot-timeout-s", o.boot_timeout_s, "Wait this long for boot-ups after Reset communication [s]")
      ->check(InRange({0.01, 600.0, "s"}))
      ->group(m);
  app.add_option("--probe-pdo-object", o.probe_pdo_object,
                 "Probe: the object (INDEX:SUB, e.g. 0x2000:00) its TPDO maps at --probe-offset-byte; checked, and "
                 "written with --configure-pdo")
      ->group(m);
  AddDeviceOptions(app, o.devices, true);
}

can::PipelineConfig MakePipelineConfig(const AcquireOptions& o) {
  can::PipelineConfig c;
  ApplyDeviceOptions(o.devices, c);
  // Gap detection: a SYNC of another producer, or of a log, comes at its own period unless given.
  if (!o.devices.sync_period_ms && (!o.replay_path.empty() || o.sync_mode == "follow")) c.sync_period_s = 0.0;
  c.mode = o.mode == "points" ? can::Mode::kPoints : can::Mode::kStream;
  c.setup = o.setup;
  c.heartbeat_timeout_s = o.heartbeat_timeout_s;
  c.standstill.tolerance_deg = o.standstill_tol_deg;
  c.standstill.dwell_s = o.dwell_s;
  c.standstill.average_s = o.average_s;
  c.standstill.min_samples = o.min_samples;
  c.Validate();
  return c;
}

can::MasterConfig MakeMasterConfig(const AcquireOptions& o, const can::PipelineConfig& pc) {
  if (o.no_nmt) {
    for (const auto& [set, name] : {std::pair{o.nmt_broadcast, "--nmt-broadcast"},
                                    {o.nmt_reset_comm, "--nmt-reset-comm"},
                                    {o.nmt_stop_at_exit, "--nmt-stop-at-exit"},
                                    {o.nmt_preop_at_exit, "--nmt-preop-at-exit"},
                                    {o.configure_pdo, "--configure-pdo"}}) {
      if (set) throw Error(std::string("--no-nmt: ") + name + " needs NMT");
    }
  }
  if (o.nmt_stop_at_exit && o.nmt_preop_at_exit) {
    throw Error("--nmt-stop-at-exit and --nmt-preop-at-exit: give one of them");
  }
  if (o.configure_pdo && o.no_sdo) throw Error("--configure-pdo: writing the TPDO settings needs SDO (no --no-sdo)");
  can::MasterConfig m;
  m.nodes = can::MasterNodesFor(pc);
  for (can::MasterNode& n : m.nodes) {
    for (can::MasterDevice& d : n.devices) {
      d.cpr_name = "--" + d.role + "-counts-per-rev";
      d.cob_name = "--" + d.role + "-cob-id";
      d.layout_name = "--" + d.role + "-offset-byte/--" + d.role + "-width-bytes";
      if (d.role == "probe" && !o.probe_pdo_object.empty()) {
        const std::string& t = o.probe_pdo_object;
        const auto colon = t.find(':');
        char* end1 = nullptr;
        char* end2 = nullptr;
        const unsigned long index = std::strtoul(t.c_str(), &end1, 16);
        const unsigned long sub = colon == std::string::npos ? 256 : std::strtoul(t.c_str() + colon + 1, &end2, 16);
        if (colon == std::string::npos || end1 != t.c_str() + colon || *end2 != '\0' || index == 0 || index > 0xFFFF ||
            sub > 0xFF) {
          throw Error("--probe-pdo-object '" + t + "': expected INDEX:SUB in hex, e.g. 0x2000:00");
        }
        d.mapped_object = can::ObjectAddress{static_cast<std::uint16_t>(index), static_cast<std::uint8_t>(sub)};
      }
    }
  }
  m.nmt = !o.no_nmt;
  m.nmt_broadcast = o.nmt_broadcast;
  m.reset_communication = o.nmt_reset_comm;
  m.sdo = !o.no_sdo;
  m.trust_config = o.trust_config;
  m.configure_pdo = o.configure_pdo;
  m.sync_counter_max = pc.sync_counter_max;
  m.sync_counter_name = "--sync-counter-max";
  m.heartbeat_ms = static_cast<std::uint16_t>(o.node_heartbeat_ms);
  m.heartbeat_name = "--node-heartbeat-ms";
  m.sdo_timeout_ns = static_cast<std::int64_t>(o.sdo_timeout_ms * 1e6);
  m.boot_timeout_ns = static_cast<std::int64_t>(o.boot_timeout_s * 1e9);
  m.Validate();
  return m;
}

int RunAcquire(const AcquireOptions& o, std::ostream& err) {
  const Logger log(err, ParseLevel(o.log_level, o.verbose));
  if (o.iface.empty() == o.replay_path.empty()) {
    log(can::LogLevel::kError, "give either --iface (live) or --replay (a candump log)");
    return kExitBadInput;
  }
  if (!o.replay_iface.empty() && o.replay_path.empty()) {
    log(can::LogLevel::kError, "--replay-iface " + o.replay_iface + ": names the interface of a replay (--replay)");
    return kExitBadInput;
  }
  can::PipelineConfig config;
  can::MasterConfig master;
  try {
    config = MakePipelineConfig(o);
    master = MakeMasterConfig(o, config);
    AcquireHeader(o);  // a bad mount rotation is bad input, before any file is made
  } catch (const std::exception& e) {
    log(can::LogLevel::kError, e.what());
    return kExitBadInput;
  }
  try {
    RunPaths paths;
    paths.Input("--config", o.config_path).Input("--replay", o.replay_path);
    paths.Output("--output", o.output_path).Output("--can-log", o.can_log_path);
  } catch (const std::exception& e) {
    log(can::LogLevel::kError, e.what());
    return kExitBadInput;
  }
  can::ReplaySource replay;
  if (!o.replay_path.empty()) {
    // Before any output file is made: a log that cannot be read, holds no frame, holds several
    // interfaces' frames and none chosen, or goes back in time is bad input.
    try {
      replay = can::CheckReplayLog(o.replay_path, o.replay_iface, "--replay-iface");
    } catch (const std::exception& e) {
      log(can::LogLevel::kError, e.what());
      return kExitBadInput;
    }
  }
  try {
    // The outputs as they are now, before the devices are started: a file that this run may not
    // continue stays as it is.
    PointsWriter::CheckContinuable(o.output_path, AcquireHeader(o), AcquirePointsOptions(o));
    if (!o.can_log_path.empty()) can::CandumpWriter::CheckContinuable(o.can_log_path);
  } catch (const std::exception& e) {
    log(can::LogLevel::kError, e.what());
    return kExitOutputError;
  }
  AcquireContext ctx{o, log, config, master, ProcessSignals(), replay, nullptr, {}};
  ctx.print_summary = [&] {
    if (!ctx.session) return;
    err << "sph_acquired: summary: " << ctx.session->Summary() << "\n";
    const std::string out = ctx.session->OutputSummary();
    if (!out.empty()) err << "sph_acquired: summary: " << out << "\n";
    err << std::flush;
  };
  int code = kExitOk;
  try {
    code = o.iface.empty() ? RunReplay(ctx) : RunLive(ctx);
    if (ctx.session && ctx.session->state() == AcquireSession::State::kOutputFailed) return kExitOutputError;
    if (ctx.session && ctx.session->state() == AcquireSession::State::kStartRefused) return kExitDeviceError;
    if (ctx.session) ctx.session->Finish();
  } catch (const OutputError& e) {
    log(can::LogLevel::kError, std::string(e.what()) + " (everything written before is intact)");
    if (ctx.session) ctx.session->Abandon();
    ctx.print_summary();
    return kExitOutputError;
  }
  ctx.print_summary();
  if (code != kExitOk) return code;
  if (ctx.session && ctx.session->state() == AcquireSession::State::kStarting) {
    log(can::LogLevel::kWarning, "stopped before the devices were started: no points file was made");
    return kExitOk;
  }
  const std::uint64_t lost = ctx.session ? ctx.session->Losses() : 0;
  if (lost > 0) {
    log(can::LogLevel::kWarning, "samples were lost: " + std::to_string(lost) + " (see the summary)");
    return kExitSamplesLost;
  }
  return kExitOk;
}

}  // namespace sph::apps
