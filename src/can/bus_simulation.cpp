// The simulated bus: its options' texts and checks, the log mode, the record and the counts.
#include "sph/can/bus_simulation.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <optional>
#include <sstream>
#include <utility>

#include "bus_simulation_internal.hpp"
#include "clock.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/output_files.hpp"

namespace sph::can {
namespace {

std::vector<std::string> Split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, sep);) out.push_back(part);
  return out;
}

int ToDevice(const std::string& s, const std::string& what) {
  if (s == "theta") return kTheta;
  if (s == "phi") return kPhi;
  if (s == "probe") return kProbe;
  throw Error(what + ": device '" + s + "' is not theta, phi or probe");
}

// A time in s of a fault's text, within ranges::kRunTimeS; `where` names the option and its value.
double TimeOf(const std::string& text, const std::string& field, const std::string& where) {
  return CheckedValue(ParseNumber(text, field, where + ": "), ranges::kRunTimeS, where + ": " + field, text);
}

void CheckFaults(const SimFaults& f) {
  CheckedValue(f.drop_probability, ranges::kProbability, "--drop-probability");
  CheckedValue(f.short_probability, ranges::kProbability, "--short-probability");
  CheckedValue(f.sync_drop_probability, ranges::kProbability, "--sync-drop-probability");
  CheckedValue(f.probe_out_of_range_probability, ranges::kProbability, "--probe-out-of-range-probability");
  CheckedValue(f.jitter_us, ranges::kJitterUs, "--jitter-us");
  CheckedValueOr(f.error_frame_period_s, 0.0, "none", ranges::kErrorFramePeriodS, "--error-frame-period-s");
  for (const double t : f.bus_off_at_s) CheckedValue(t, ranges::kRunTimeS, "--bus-off-at-s");
  for (const Silence& s : f.silences) {
    const std::string what = "--silence " + std::string(DeviceName(s.device)) + ":" + internal::Shortest(s.from_s) +
                             ":" + internal::Shortest(s.to_s);
    if (s.device < 0 || s.device >= kNumDevices) throw Error("--silence: device " + std::to_string(s.device));
    CheckedValue(s.from_s, ranges::kRunTimeS, what + ": from_s");
    CheckedValue(s.to_s, ranges::kRunTimeS, what + ": to_s");
    if (!(s.from_s < s.to_s)) throw Error(what + ": the window must end after it begins (from_s < to_s)");
  }
  for (const EmcyEvent& e : f.emergencies) {
    if (e.device < 0 || e.device >= kNumDevices) throw Error("--emcy: device " + std::to_string(e.device));
    CheckedValue(e.at_s, ranges::kRunTimeS, "--emcy: at_s");
  }
  for (const RebootEvent& r : f.reboots) CheckedValue(r.at_s, ranges::kRunTimeS, "--fault: T");
}

void CheckTimes(const BusSimulationOptions& o) {
  const DeviceSimConfig& c = o.sim;
  CheckedValue(c.move_s, ranges::kStepTimeS, "--move-s");
  CheckedValue(c.stop_s, ranges::kStepTimeS, "--stop-s");
  CheckedValueOr(c.heartbeat_period_s, 0.0, "none", ranges::kHeartbeatPeriodS, "--heartbeat-period-s");
  CheckedValue(c.start_time_s, ranges::kEpochTimeS, "--start-time-s");
  CheckedValue(c.boot_s, ranges::kBootS, "--boot-s");
  CheckedValue(c.transmission_type, ranges::kTransmissionType, "--transmission-type");
  CheckedValue(c.sync_counter_overflow, ranges::kNodesSyncCounterMax, "--nodes-sync-counter-max");
  CheckedValue(o.duration_s, ranges::kRunTimeS, "--duration-s");
  if (o.devices.sync_period_ms) CheckedValue(*o.devices.sync_period_ms, ranges::kSyncPeriodMs, "--sync-period-ms");
}

// The simulator's configuration for a log (`live` false) or a live play.
DeviceSimConfig SimConfig(const BusSimulationOptions& o, bool live) {
  DeviceSimConfig c = o.sim;
  c.devices = DevicesConfig(o.devices);
  c.sync_period_s = c.devices.sync_period_s;
  if (c.sync_counter_overflow == 1) throw Error("--nodes-sync-counter-max: 1 is not allowed (-1, 0 or 2..240)");
  c.start_operational = !live || o.boot_operational;
  c.Validate();
  const auto points = static_cast<double>(c.spec.pattern.size());
  const double end_s = c.start_time_s + points * c.stop_s + (points - 1.0) * c.move_s;
  if (!(end_s < ranges::kEpochTimeS.hi)) {
    throw Error("--start-time-s " + internal::Format("%.0f", c.start_time_s) + ": the simulation would end at " +
                internal::Format("%.0f", end_s) + " s since the epoch, beyond the " +
                internal::Format("%g", ranges::kEpochTimeS.hi) + " s that a frame time in ns holds");
  }
  return c;
}

// Where the log's lines go, as they are made: a file descriptor, written in blocks of 64 KiB.
class LogSink {
 public:
  LogSink(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  void Add(const std::string& line) {
    pending_ += line;
    if (pending_.size() >= 65536) Drain();
  }
  /// Writes what is pending; throws sph::Error naming the path when a write failed.
  void Finish() {
    Drain();
    if (error_ == 0) return;
    if (path_ == "-") throw Error(std::string("cannot write to standard output: ") + std::strerror(error_));
    throw Error(path_ + ": cannot write: " + std::strerror(error_));
  }

 private:
  void Drain() {
    const char* p = pending_.data();
    std::size_t left = error_ == 0 ? pending_.size() : 0;
    while (left > 0) {
      const ssize_t n = ::write(fd_, p, left);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) {
        error_ = errno;
        break;
      }
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    pending_.clear();
  }

  int fd_;
  std::string path_;
  std::string pending_;
  int error_ = 0;
};

// The file the log is written into: standard output, the FIFO or character device itself, or a
// temporary file beside a regular file (or a new name) that `files` puts in place at the end.
struct LogTarget {
  int fd = -1;
  bool owned = false;  ///< fd is ours to close
  std::string staged;  ///< the temporary file, when staged
};

LogTarget OpenLogTarget(const std::string& path, OutputFiles& files) {
  LogTarget t;
  if (path == "-") {
    std::cout.flush();
    t.fd = STDOUT_FILENO;
    return t;
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode))) {
    t.fd = ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
    if (t.fd < 0) throw Error(path + ": cannot open for writing: " + std::strerror(errno));
    t.owned = true;
    return t;
  }
  t.staged = files.StageProduced(path);  // refuses a directory, a block device, a socket
  t.fd = ::open(t.staged.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (t.fd < 0) throw Error(path + ": cannot write: " + std::strerror(errno));
  t.owned = true;
  return t;
}

// Writes the whole pattern's frames into the log (staged in `files`); false when a stop cut it
// short. Throws sph::Error when the log cannot be written.
bool WriteLog(const BusSimulationOptions& o, DeviceSimulator& sim, const RunControl& control, OutputFiles& files,
              LogTarget& target) {
  target = OpenLogTarget(o.output_path, files);
  LogSink sink(target.fd, o.output_path);
  std::vector<CanFrame> frames;
  std::string line;
  while (control.stop.load() == 0 && sim.NextCycle(frames)) {
    for (const CanFrame& fr : frames) {
      line = FormatCandumpLine(fr, o.log_iface);
      line += '\n';
      sink.Add(line);
    }
    frames.clear();
  }
  sink.Finish();
  if (!target.staged.empty() && ::fsync(target.fd) != 0) {
    throw Error(o.output_path + ": cannot write: " + std::strerror(errno));
  }
  if (target.owned && ::close(std::exchange(target.fd, -1)) != 0) {
    throw Error(o.output_path + ": cannot write: " + std::strerror(errno));
  }
  return control.stop.load() == 0;
}

}  // namespace

Silence ParseSilence(const std::string& s) {
  const auto p = Split(s, ':');
  if (p.size() != 3) throw Error("--silence '" + s + "': expected device:from_s:to_s");
  const std::string what = "--silence '" + s + "'";
  const double from = TimeOf(p[1], "from_s", what);
  const double to = TimeOf(p[2], "to_s", what);
  if (!(from < to)) throw Error(what + ": the window must end after it begins (from_s < to_s)");
  return {ToDevice(p[0], "--silence"), from, to};
}

EmcyEvent ParseEmcy(const std::string& s) {
  const auto p = Split(s, ':');
  if (p.size() != 3) throw Error("--emcy '" + s + "': expected device:at_s:code");
  unsigned long long code = 0;
  if (!ParseHex(p[2], 0xFFFF, &code)) throw Error("--emcy '" + s + "': code must be 16-bit hex");
  const double at = TimeOf(p[1], "at_s", "--emcy '" + s + "'");
  return {ToDevice(p[0], "--emcy"), at, static_cast<std::uint16_t>(code)};
}

RebootEvent ParseFault(const std::string& s, const DeviceOptions& devices) {
  const auto at = s.find('@');
  const bool lost = s.rfind("settings-lost:", 0) == 0;
  const bool preop = s.rfind("preop:", 0) == 0, error = s.rfind("error:", 0) == 0;
  if ((s.rfind("reboot:", 0) != 0 && !lost && !preop && !error) || at == std::string::npos) {
    throw Error("--fault '" + s +
                "': expected reboot:NODE@T, settings-lost:NODE@T, preop:NODE@T or error:NODE@T (NODE a node id or "
                "theta, phi, probe; T in s)");
  }
  const std::size_t colon = s.find(':') + 1;
  const std::string node = s.substr(colon, at - colon);
  int id = 0;
  if (node == "theta" || node == "phi" || node == "probe") {
    const int d = ToDevice(node, "--fault");
    id = d == kTheta ? devices.theta.node : d == kPhi ? devices.phi.node : devices.probe_node;
  } else {
    try {
      id = ParseInteger(node, "node", "");
    } catch (const Error&) {
      id = 0;
    }
    if (id < 1 || id > 127) throw Error("--fault '" + s + "': node must be 1..127");
  }
  RebootEvent r{id, TimeOf(s.substr(at + 1), "T", "--fault '" + s + "'"), lost};
  if (preop) r.kind = NodeFaultKind::kPreOperational;
  if (error) r.kind = NodeFaultKind::kError;
  return r;
}

void CheckBusSimulationOptions(const BusSimulationOptions& o) {
  if (o.output_path.empty() == o.iface.empty()) throw Error("give either --output (a candump log) or --iface (live)");
  if (o.external_sync && o.iface.empty()) throw Error("--sync-source external needs --iface");
  CheckTimes(o);
  CheckFaults(o.sim.faults);
  SimConfig(o, !o.iface.empty());
}

void WriteRecord(const std::vector<SimCycleRecord>& records, std::ostream& out) {
  out << "# sph_cansim record: sync_t_s counter theta_deg phi_deg r_mm\n";
  char buf[160];
  for (const SimCycleRecord& r : records) {
    std::snprintf(buf, sizeof buf, "%.6f %s", static_cast<double>(r.sync_ns) * 1e-9,
                  r.counter ? std::to_string(*r.counter).c_str() : "-");
    out << buf;
    for (int d = 0; d < kNumDevices; ++d) {
      if (r.sent[static_cast<std::size_t>(d)]) {
        std::snprintf(buf, sizeof buf, " %.10f", r.value[static_cast<std::size_t>(d)]);
        out << buf;
      } else {
        out << " -";
      }
    }
    out << "\n";
  }
}

std::string FormatInjected(const SimInjected& in) {
  std::ostringstream s;
  s << "cycles " << in.cycles << ", SYNC dropped " << in.syncs_dropped << ", PDOs sent theta/phi/probe " << in.pdos[0]
    << "/" << in.pdos[1] << "/" << in.pdos[2] << ", dropped " << in.dropped[0] << "/" << in.dropped[1] << "/"
    << in.dropped[2] << ", shortened " << in.shortened[0] << "/" << in.shortened[1] << "/" << in.shortened[2]
    << ", silent cycles " << in.silent_cycles[0] << "/" << in.silent_cycles[1] << "/" << in.silent_cycles[2]
    << ", probe out of range " << in.probe_out_of_range << ", error frames " << in.error_frames << " (bus-off "
    << in.bus_off << "), EMCY " << in.emergencies << ", heartbeats " << in.heartbeats << ", reboots " << in.reboots
    << ", boot-ups " << in.boot_ups << ", NMT commands " << in.nmt_commands << ", SDO requests " << in.sdo_requests
    << " (aborted " << in.sdo_aborts << ")";
  return s.str();
}

// ---- the run: the checks, the simulator, the log or the play, the record

BusSimulationResult BusRun::Begin(bool live) {
  try {
    CheckBusSimulationOptions(o);
    RunPaths paths;
    for (const auto& [option, path] : o.option_files) paths.Input(option, path);
    paths.Output("--output", o.output_path).Output("--record", o.record_path);
    config = SimConfig(o, live);
    if (live) config.start_time_s = static_cast<double>(RealtimeNs()) * 1e-9;  // power-on now
    sim.emplace(config);
  } catch (const std::exception& e) {
    return Fail(BusSimulationStatus::kBadInput, e.what());
  }
  sim->set_recording(!o.record_path.empty());
  result.cycles = sim->total_cycles();
  result.duration_s = sim->duration_s();
  std::ostringstream s;
  s << sim->total_cycles() << " SYNC cycles, " << sim->duration_s() << " s";
  Report(LogLevel::kInfo, s.str());
  return result;
}

BusSimulationResult BusRun::End() {
  result.injected = sim->injected();
  Report(LogLevel::kInfo, FormatInjected(result.injected));
  try {
    if (!o.record_path.empty()) {
      files.Stage(o.record_path, [&](std::ostream& out) { WriteRecord(sim->records(), out); });
    }
    files.Commit();
  } catch (const std::exception& e) {
    return Fail(BusSimulationStatus::kOutputError, e.what());
  }
  return result;
}

BusSimulationResult BusRun::Fail(BusSimulationStatus status, const std::string& error) {
  Report(LogLevel::kError, error);
  result.status = status;
  result.error = error;
  return result;
}

void BusRun::Report(LogLevel level, const std::string& text) const {
  if (hooks.log) hooks.log(level, text);
}

BusSimulationResult SimulateBusLog(const BusSimulationOptions& options, RunControl& control,
                                   const BusSimulationHooks& hooks) {
  BusRun run(options, control, hooks);
  if (run.Begin(false).status != BusSimulationStatus::kOk) return run.result;
  LogTarget target;
  bool complete = false;
  try {
    complete = WriteLog(options, *run.sim, control, run.files, target);
  } catch (const std::exception& e) {
    if (target.owned && target.fd >= 0) ::close(target.fd);
    return run.Fail(BusSimulationStatus::kOutputError, e.what());
  }
  if (!complete) {
    run.result.status = BusSimulationStatus::kStopped;
    run.result.stopped_by = control.stop.load();
    run.Report(LogLevel::kInfo, "stopped by signal " + std::to_string(run.result.stopped_by) + ": " +
                                    (target.staged.empty() ? "the log is incomplete" : "no log written"));
    return run.result;  // `files` removes the log begun
  }
  return run.End();
}

}  // namespace sph::can
