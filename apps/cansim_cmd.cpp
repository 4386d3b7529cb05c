#include "cansim_cmd.hpp"

#include <time.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "acquire_cmd.hpp"
#include "app_common.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/socket.hpp"
#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

std::vector<std::string> Split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, sep);) out.push_back(part);
  return out;
}

double ToDouble(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0') throw Error(what + ": '" + s + "' is not a number");
  return v;
}

int ToDevice(const std::string& s, const std::string& what) {
  if (s == "theta") return can::kTheta;
  if (s == "phi") return can::kPhi;
  if (s == "probe") return can::kProbe;
  throw Error(what + ": device '" + s + "' is not theta, phi or probe");
}

std::int64_t MonotonicNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void SleepUntilMono(std::int64_t ns) {
  timespec ts{static_cast<time_t>(ns / 1000000000), static_cast<long>(ns % 1000000000)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    if (ProcessSignals().stop) return;
  }
}

void PrintInjected(const can::SimInjected& in, std::ostream& err) {
  err << "sph_cansim: cycles " << in.cycles << ", SYNC dropped " << in.syncs_dropped << ", PDOs dropped theta/phi/probe "
      << in.dropped[0] << "/" << in.dropped[1] << "/" << in.dropped[2] << ", shortened " << in.shortened[0] << "/"
      << in.shortened[1] << "/" << in.shortened[2] << ", silent cycles " << in.silent_cycles[0] << "/"
      << in.silent_cycles[1] << "/" << in.silent_cycles[2] << ", probe out of range " << in.probe_out_of_range
      << ", error frames " << in.error_frames << " (bus-off " << in.bus_off << "), EMCY " << in.emergencies
      << ", heartbeats " << in.heartbeats << "\n";
}

// Plays onto a CAN interface in real time.
int PlayLive(const CansimOptions& o, can::DeviceSimulator& sim, std::ostream& err) {
  can::CanSocketOptions so;
  so.iface = o.iface;
  const bool external = o.sync_source == "external";
  so.filters.emplace_back(o.devices.sync_cob_id, can::kEffFlag | can::kRtrFlag | can::kSffMask);
  so.error_mask = 0;
  std::optional<can::CanSocket> sock;
  try {
    sock.emplace(so);
  } catch (const std::exception& e) {
    err << "sph_cansim: error: " << e.what() << "\n";
    return kExitInterfaceError;
  }
  std::vector<can::CanFrame> frames;
  std::uint64_t sent = 0, failed = 0;
  const std::int64_t mono0 = MonotonicNs();
  auto send_all = [&](std::int64_t sim_base_ns, std::int64_t mono_base_ns) {
    for (const can::CanFrame& f : frames) {
      SleepUntilMono(mono_base_ns + (f.t_ns - sim_base_ns));
      if (ProcessSignals().stop) return;
      if (sock->Send(f) == can::TxStatus::kOk) ++sent;
      else ++failed;
    }
  };
  const auto start_ns = static_cast<std::int64_t>(std::llround(o.start_time_s * 1e9));
  while (!ProcessSignals().stop) {
    frames.clear();
    if (!external) {
      if (!sim.NextCycle(frames)) break;
      send_all(start_ns, mono0);
    } else {
      const can::RxResult r = sock->Receive(200);
      if (r.status != can::RxStatus::kFrame || !can::DecodeSync(r.frame, o.devices.sync_cob_id)) continue;
      const std::int64_t mono_now = MonotonicNs();
      if (!sim.AnswerSync(r.frame.t_ns, frames)) break;
      send_all(r.frame.t_ns, mono_now);
    }
  }
  err << "sph_cansim: " << o.iface << ": sent " << sent << " frames, " << failed << " failed\n";
  return kExitOk;
}

}  // namespace

void SetupCansimApp(CLI::App& app, CansimOptions& o) {
  app.description("Simulate an SCMS measuring a reference sphere (stop-and-go) as CANopen traffic: SYNC, CiA 406 "
                  "encoder TPDOs, the probe TPDO and heartbeats, with faults on demand; into a candump log or onto "
                  "a CAN interface.");
  app.option_defaults()->always_capture_default();
  app.set_config("--config", "", "Read options from this file (the device options of sph_acquired's config fit)");
  auto* out = app.add_option("-o,--output", o.output_path, "Candump log to write ('-' for stdout)");
  auto* iface = app.add_option("-i,--iface", o.iface, "CAN interface to play onto, in real time")->excludes(out);
  out->excludes(iface);
  app.add_option("--log-iface", o.log_iface, "Interface name written into the log");
  app.add_option("--sync-source", o.sync_source, "internal: send SYNC; external (live only): answer received SYNCs")
      ->check(CLI::IsMember({"internal", "external"}));
  const std::string m = "Machine";
  AddMachineOptions(app, o.machine, m);
  app.add_option("--center-mm", o.center_mm, "Sphere centre x,y,z [mm]")->group(m);
  app.add_option("--seed", o.seed, "Random seed")->group(m);
  app.add_option("--move-s", o.move_s, "Time to move between pattern points [s]")->check(NonNegative())->group(m);
  app.add_option("--stop-s", o.stop_s, "Standstill at each pattern point [s]")->check(NonNegative())->group(m);
  app.add_option("--heartbeat-period-s", o.heartbeat_period_s, "Heartbeat period of every node [s]; 0: none")
      ->check(NonNegative())->group(m);
  app.add_option("--start-time-s", o.start_time_s, "Log: time of the first SYNC [s since the epoch]")->group(m);
  const std::string f = "Faults";
  app.add_option("--drop-probability", o.drop_probability, "Each PDO is lost with this probability")
      ->check(CLI::Range(0.0, 1.0))->group(f);
  app.add_option("--short-probability", o.short_probability, "Each PDO loses its last byte (malformed)")
      ->check(CLI::Range(0.0, 1.0))->group(f);
  app.add_option("--sync-drop-probability", o.sync_drop_probability, "Each SYNC is lost")
      ->check(CLI::Range(0.0, 1.0))->group(f);
  app.add_option("--probe-out-of-range-probability", o.probe_out_of_range_probability,
                 "The probe sends its over-range code")->check(CLI::Range(0.0, 1.0))->group(f);
  app.add_option("--jitter-us", o.jitter_us, "Extra PDO delay, uniform in [0, jitter] [us]")
      ->check(NonNegative())->group(f);
  app.add_option("--error-frame-period-s", o.error_frame_period_s, "An error frame (controller problem) this often [s]")
      ->check(NonNegative())->group(f);
  app.add_option("--bus-off-at-s", o.bus_off_at_s, "A bus-off error frame at this time after the start [s] (repeatable)")
      ->group(f);
  app.add_option("--silence", o.silences, "device:from_s:to_s: the device sends nothing then (repeatable)")->group(f);
  app.add_option("--emcy", o.emergencies, "device:at_s:code: an EMCY frame, code in hex (repeatable)")->group(f);
  AddDeviceOptions(app, o.devices);
}

can::DeviceSimConfig MakeDeviceSimConfig(const CansimOptions& o) {
  can::DeviceSimConfig c;
  c.spec = ToSimulationSpec(o.machine);
  c.spec.centers_mm = {ParseVector3(o.center_mm, "--center-mm")};
  c.spec.seed = o.seed;
  ApplyDeviceOptions(o.devices, c.devices);
  c.sync_period_s = o.devices.sync_period_ms * 1e-3;
  c.move_s = o.move_s;
  c.stop_s = o.stop_s;
  c.heartbeat_period_s = o.heartbeat_period_s;
  c.start_time_s = o.start_time_s;
  can::SimFaults& f = c.faults;
  f.drop_probability = o.drop_probability;
  f.short_probability = o.short_probability;
  f.sync_drop_probability = o.sync_drop_probability;
  f.probe_out_of_range_probability = o.probe_out_of_range_probability;
  f.jitter_us = o.jitter_us;
  f.error_frame_period_s = o.error_frame_period_s;
  f.bus_off_at_s = o.bus_off_at_s;
  for (const std::string& s : o.silences) {
    const auto p = Split(s, ':');
    if (p.size() != 3) throw Error("--silence '" + s + "': expected device:from_s:to_s");
    f.silences.push_back({ToDevice(p[0], "--silence"), ToDouble(p[1], "--silence"), ToDouble(p[2], "--silence")});
  }
  for (const std::string& s : o.emergencies) {
    const auto p = Split(s, ':');
    if (p.size() != 3) throw Error("--emcy '" + s + "': expected device:at_s:code");
    char* end = nullptr;
    const unsigned long code = std::strtoul(p[2].c_str(), &end, 16);
    if (p[2].empty() || *end != '\0' || code > 0xFFFF) throw Error("--emcy '" + s + "': code must be 16-bit hex");
    f.emergencies.push_back({ToDevice(p[0], "--emcy"), ToDouble(p[1], "--emcy"), static_cast<std::uint16_t>(code)});
  }
  return c;
}

int RunCansim(const CansimOptions& o, std::ostream& err) {
  if (o.output_path.empty() == o.iface.empty()) {
    err << "sph_cansim: error: give either --output (a candump log) or --iface (live)\n";
    return kExitBadInput;
  }
  if (o.sync_source == "external" && o.iface.empty()) {
    err << "sph_cansim: error: --sync-source external needs --iface\n";
    return kExitBadInput;
  }
  std::optional<can::DeviceSimulator> sim;
  try {
    sim.emplace(MakeDeviceSimConfig(o));
  } catch (const std::exception& e) {
    err << "sph_cansim: error: " << e.what() << "\n";
    return kExitBadInput;
  }
  err << "sph_cansim: " << sim->total_cycles() << " SYNC cycles, " << sim->duration_s() << " s\n";
  int code = kExitOk;
  if (!o.iface.empty()) {
    code = PlayLive(o, *sim, err);
  } else {
    std::ofstream file;
    if (o.output_path != "-") {
      file.open(o.output_path, std::ios::binary | std::ios::trunc);
      if (!file) {
        err << "sph_cansim: error: " << o.output_path << ": cannot open for writing: " << std::strerror(errno) << "\n";
        return kExitOutputError;
      }
    }
    std::ostream& out = o.output_path == "-" ? std::cout : file;
    std::vector<can::CanFrame> frames;
    std::string line;
    while (!ProcessSignals().stop && sim->NextCycle(frames)) {
      for (const can::CanFrame& fr : frames) {
        line = can::FormatCandumpLine(fr, o.log_iface);
        line += '\n';
        out.write(line.data(), static_cast<std::streamsize>(line.size()));
      }
      frames.clear();
    }
    out.flush();
    if (!out) {
      err << "sph_cansim: error: " << o.output_path << ": write failed\n";
      return kExitOutputError;
    }
  }
  PrintInjected(sim->injected(), err);
  return code;
}

}  // namespace sph::apps
