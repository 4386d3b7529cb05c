#include "cansim_cmd.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

#include <CLI/CLI.hpp>

#include "acquire_cmd.hpp"
#include "app_common.hpp"
#include "can_options.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/sdo.hpp"
#include "sph/can/socket.hpp"
#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

constexpr ValidRange kStepTimeS{0.0, 3600.0, "s"};
constexpr ValidRange kProbability{0.0, 1.0, ""};

// sph_acquired's options: a config file may hold them for the daemon (one file describes both).
std::shared_ptr<CLI::App> AcquiredOptionNames() {
  auto both = std::make_shared<std::pair<AcquireOptions, CLI::App>>();
  SetupAcquireApp(both->second, both->first);
  return std::shared_ptr<CLI::App>(both, &both->second);
}

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

std::int64_t RealtimeNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void PrintInjected(const can::SimInjected& in, std::ostream& err) {
  err << "sph_cansim: cycles " << in.cycles << ", SYNC dropped " << in.syncs_dropped << ", PDOs sent theta/phi/probe "
      << in.pdos[0] << "/" << in.pdos[1] << "/" << in.pdos[2] << ", dropped " << in.dropped[0] << "/" << in.dropped[1]
      << "/" << in.dropped[2] << ", shortened " << in.shortened[0] << "/" << in.shortened[1] << "/" << in.shortened[2]
      << ", silent cycles " << in.silent_cycles[0] << "/" << in.silent_cycles[1] << "/" << in.silent_cycles[2]
      << ", probe out of range " << in.probe_out_of_range << ", error frames " << in.error_frames << " (bus-off "
      << in.bus_off << "), EMCY " << in.emergencies << ", heartbeats " << in.heartbeats << ", reboots " << in.reboots
      << ", boot-ups " << in.boot_ups << ", NMT commands " << in.nmt_commands << ", SDO requests " << in.sdo_requests
      << " (aborted " << in.sdo_aborts << ")\n";
}

// One line per SYNC the devices answered: its time, its counter (- without), and per device the
// value the daemon decodes from the PDO sent (- when none or not a valid one).
void WriteRecord(const std::vector<can::SimCycleRecord>& records, std::ostream& out) {
  out << "# sph_cansim record: sync_t_s counter theta_deg phi_deg r_mm\n";
  char buf[160];
  for (const can::SimCycleRecord& r : records) {
    std::snprintf(buf, sizeof buf, "%.6f %s", static_cast<double>(r.sync_ns) * 1e-9,
                  r.counter ? std::to_string(*r.counter).c_str() : "-");
    out << buf;
    for (int d = 0; d < can::kNumDevices; ++d) {
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

// Plays the devices on a CAN interface in real time: they answer SYNC, NMT and SDO frames from
// the bus and send heartbeats and boot-ups on their own; with the internal SYNC source the
// simulator is also the SYNC producer.
// The CAN socket of a live play: the frames the devices listen to (SYNC, NMT, their SDO requests).
can::CanSocketOptions LiveSocketOptions(const CansimOptions& o, const can::DeviceSimConfig& c) {
  can::CanSocketOptions so;
  so.iface = o.iface;
  const std::uint32_t sff = can::kEffFlag | can::kRtrFlag | can::kSffMask;
  so.filters.emplace_back(o.devices.sync_cob_id, sff);
  so.filters.emplace_back(can::kNmtCobId, sff);
  for (const int node : {c.devices.theta.node_id, c.devices.phi.node_id, c.devices.probe.node_id}) {
    if (node != 0) so.filters.emplace_back(can::kSdoRequestBase + static_cast<std::uint32_t>(node), sff);
  }
  so.error_mask = 0;
  return so;
}

// The devices on a live interface, paced in real time: frames planned by the simulator are sent
// at their times; a synchronous PDO remembers its SYNC, because it must not go out once its
// synchronous window has closed (CiA 301, object 1007h): when the next SYNC came first, or half a
// period after its own. A real device drops it then; a simulator slowed down (an emulated machine)
// would otherwise answer one SYNC after the next.
class LivePlay {
 public:
  LivePlay(const CansimOptions& o, can::DeviceSimulator& sim, const can::DeviceSimConfig& c, can::CanSocket& sock)
      : o_(o),
        sim_(sim),
        c_(c),
        sock_(sock),
        external_(o.sync_source == "external"),
        period_ns_(static_cast<std::int64_t>(std::llround(c.sync_period_s * 1e9))),
        // The synchronous window (1007h): half a period, so that a SYNC of a producer that is late
        // by less than that, and the early one after it, still find each PDO in its own period.
        window_ns_(period_ns_ / 2),
        start_ns_(static_cast<std::int64_t>(std::llround(c.start_time_s * 1e9))),
        end_ns_(o.duration_s > 0.0 ? start_ns_ + static_cast<std::int64_t>(o.duration_s * 1e9)
                                   : std::numeric_limits<std::int64_t>::max()),
        next_sync_(external_ ? std::numeric_limits<std::int64_t>::max() : start_ns_),
        pdo_ids_{c.devices.theta.field.can_id, c.devices.phi.field.can_id, c.devices.probe.field.can_id} {}

  void Run() {
    while (!ProcessControl().stop.load()) {
      // Take every frame queued first: a SYNC waiting in the queue closes the window before.
      for (int i = 0; i < 64; ++i) {
        const can::RxResult r = sock_.Receive();
        if (r.status != can::RxStatus::kFrame) break;
        Deliver(r.frame);
      }
      const std::int64_t now = RealtimeNs();
      if (now >= end_ns_ || (sim_.finished() && pending_.empty())) break;
      SendDue(now);
      if (!external_ && now >= next_sync_ && !sim_.finished()) {
        SendSync();
        continue;
      }
      Wait(now);
    }
  }

  void Summarise(std::ostream& err) const {
    if (late_ > 0) {
      err << "sph_cansim: " << late_
          << " PDOs not sent: their synchronous window had closed (the simulator was late)\n";
    }
    err << "sph_cansim: " << o_.iface << ": sent " << sent_ << " frames, " << failed_ << " failed\n";
  }

 private:
  struct Planned {
    can::CanFrame frame;
    std::int64_t sync_ns = 0;  // the SYNC a synchronous PDO answers; 0: not one
  };

  // The devices take `frame` (received, or the simulator's own SYNC); their answers are planned.
  void Deliver(const can::CanFrame& frame) {
    out_.clear();
    sim_.AdvanceTo(frame.t_ns, out_);
    const bool sync = can::DecodeSync(frame, c_.devices.sync_cob_id).has_value();
    if (sync) last_sync_ = frame.t_ns;
    const std::size_t before = out_.size();
    sim_.OnFrame(frame, out_);
    for (std::size_t i = 0; i < out_.size(); ++i) {
      const bool pdo =
          i >= before && sync && std::find(std::begin(pdo_ids_), std::end(pdo_ids_), out_[i].id) != std::end(pdo_ids_);
      pending_.push_back({out_[i], pdo ? frame.t_ns : 0});
    }
  }

  // Sends the planned frames due at `now`, in time order, but a synchronous PDO whose window closed.
  void SendDue(std::int64_t now) {
    std::stable_sort(pending_.begin(), pending_.end(),
                     [](const Planned& a, const Planned& b) { return a.frame.t_ns < b.frame.t_ns; });
    std::size_t k = 0;
    arrived_.clear();
    for (; k < pending_.size() && pending_[k].frame.t_ns <= now; ++k) {
      const Planned& p = pending_[k];
      if (p.sync_ns != 0) {
        // Just before a synchronous PDO: a SYNC queued meanwhile closes its window.
        for (int i = 0; i < 64; ++i) {
          const can::RxResult r = sock_.Receive();
          if (r.status != can::RxStatus::kFrame) break;
          arrived_.push_back(r.frame);
          if (can::DecodeSync(r.frame, c_.devices.sync_cob_id)) last_sync_ = std::max(last_sync_, r.frame.t_ns);
        }
        if (p.sync_ns < last_sync_ || RealtimeNs() - p.sync_ns > window_ns_) {
          ++late_;
          continue;
        }
      }
      if (sock_.Send(p.frame) == can::TxStatus::kOk) {
        ++sent_;
      } else {
        ++failed_;
      }
    }
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(k));
    for (const can::CanFrame& f : arrived_) Deliver(f);
  }

  // The simulator's own SYNC, at its time.
  void SendSync() {
    can::CanFrame sync = can::EncodeSync(
        c_.devices.sync_counter_max != 0
            ? std::optional<std::uint8_t>(counter_ = can::NextSyncCounter(counter_, c_.devices.sync_counter_max))
            : std::nullopt,
        c_.devices.sync_cob_id);
    sync.t_ns = next_sync_;
    pending_.push_back({sync, 0});
    Deliver(sync);
    next_sync_ += period_ns_;
  }

  // Plans what the devices send on their own, then waits for a frame until the next thing to do.
  void Wait(std::int64_t now) {
    out_.clear();
    sim_.AdvanceTo(now, out_);
    for (const can::CanFrame& f : out_) pending_.push_back({f, 0});
    std::int64_t wake = std::min({sim_.NextEventNs(), next_sync_, end_ns_});
    for (const Planned& p : pending_) wake = std::min(wake, p.frame.t_ns);
    const std::int64_t wait_ns = std::max<std::int64_t>(0, std::min<std::int64_t>(wake - now, 200000000));
    const can::RxResult r = sock_.Receive(static_cast<int>((wait_ns + 999999) / 1000000));
    if (r.status == can::RxStatus::kFrame) Deliver(r.frame);
  }

  const CansimOptions& o_;
  can::DeviceSimulator& sim_;
  const can::DeviceSimConfig& c_;
  can::CanSocket& sock_;
  const bool external_;
  const std::int64_t period_ns_, window_ns_, start_ns_, end_ns_;
  std::int64_t next_sync_;
  const std::uint32_t pdo_ids_[3];
  std::vector<Planned> pending_;
  std::vector<can::CanFrame> out_, arrived_;
  std::uint64_t sent_ = 0, failed_ = 0, late_ = 0;
  std::int64_t last_sync_ = 0;
  std::uint8_t counter_ = 0;
};

int PlayLive(const CansimOptions& o, can::DeviceSimulator& sim, const can::DeviceSimConfig& c, std::ostream& err) {
  std::optional<can::CanSocket> sock;
  try {
    sock.emplace(LiveSocketOptions(o, c));
  } catch (const std::exception& e) {
    err << "sph_cansim: error: " << e.what() << "\n";
    return kExitInterfaceError;
  }
  LivePlay play(o, sim, c, *sock);
  play.Run();
  play.Summarise(err);
  return kExitOk;
}

}  // namespace

void SetupCansimApp(CLI::App& app, CansimOptions& o) {
  app.description(
      "Simulate an SCMS measuring a reference sphere (stop-and-go) as CANopen traffic: SYNC, CiA 406 "
      "encoder TPDOs, the probe TPDO and heartbeats, with faults on demand; into a candump log or onto "
      "a CAN interface.");
  app.option_defaults()->always_capture_default();
  app.set_config("--config", "", "Read options from this file (the device options of sph_acquired's config fit)");
  UseStrictConfig(app, "sph_cansim", &o.config_path, AcquiredOptionNames());
  auto* out = app.add_option("-o,--output", o.output_path, "Candump log to write ('-' for stdout)");
  auto* iface = app.add_option("-i,--iface", o.iface, "CAN interface to play onto, in real time")
                    ->check(InterfaceName())
                    ->excludes(out);
  out->excludes(iface);
  app.add_option("--log-iface", o.log_iface, "Interface name written into the log")->check(InterfaceName());
  app.add_option("--sync-source", o.sync_source, "internal: send SYNC; external (live only): answer received SYNCs")
      ->check(CLI::IsMember({"internal", "external"}));
  const std::string m = "Machine";
  AddMachineOptions(app, o.machine, m);
  app.add_option("--center-mm", o.center_mm, "Sphere centre x,y,z [mm]")->group(m);
  app.add_option("--mount-rotation-deg", o.mount_rotation_deg,
                 "rx,ry,rz: the rotation vector (axis times angle) [deg] that takes the sphere's body frame into the "
                 "frame turning with Theta (each " +
                     ranges::kMountRotationDeg.Text() +
                     "); the form below turns with it (give it to sph_acquired for the points file's header)")
      ->group(m);
  AddFormOptions(app, o.form, m);
  app.add_option("--seed", o.seed, "Random seed")->group(m);
  app.add_option("--move-s", o.move_s, "Time to move between pattern points [s]")->check(InRange(kStepTimeS))->group(m);
  app.add_option("--stop-s", o.stop_s, "Standstill at each pattern point [s]")->check(InRange(kStepTimeS))->group(m);
  app.add_option("--heartbeat-period-s", o.heartbeat_period_s,
                 "Heartbeat period of every node [s] (1017h holds whole ms up to 65535); 0: none")
      ->check(ZeroOrInRange({0.001, 65.535, "s"}, "none"))
      ->group(m);
  app.add_option("--start-time-s", o.start_time_s, "Log: time of the first SYNC [s since the epoch]")
      ->check(InRange(can::ranges::kEpochTimeS))
      ->group(m);
  const std::string f = "Faults";
  app.add_option("--drop-probability", o.drop_probability, "Each PDO is lost with this probability")
      ->check(InRange(kProbability))
      ->group(f);
  app.add_option("--short-probability", o.short_probability, "Each PDO loses its last byte (malformed)")
      ->check(InRange(kProbability))
      ->group(f);
  app.add_option("--sync-drop-probability", o.sync_drop_probability, "Each SYNC is lost")
      ->check(InRange(kProbability))
      ->group(f);
  app.add_option("--probe-out-of-range-probability", o.probe_out_of_range_probability,
                 "The probe sends its over-range code")
      ->check(InRange(kProbability))
      ->group(f);
  app.add_option("--jitter-us", o.jitter_us, "Extra PDO delay, uniform in [0, jitter] [us]")
      ->check(InRange({0.0, 1e6, "us"}))
      ->group(f);
  app.add_option("--error-frame-period-s", o.error_frame_period_s,
                 "An error frame (controller problem) this often [s]; 0: none")
      ->check(ZeroOrInRange({0.001, 86400.0, "s"}, "none"))
      ->group(f);
  app.add_option("--bus-off-at-s", o.bus_off_at_s,
                 "A bus-off error frame at this time after the start [s] (repeatable)")
      ->check(InRange(can::ranges::kRunTimeS))
      ->group(f);
  app.add_option("--silence", o.silences, "device:from_s:to_s: the device sends nothing then (repeatable)")->group(f);
  app.add_option("--emcy", o.emergencies, "device:at_s:code: an EMCY frame, code in hex (repeatable)")->group(f);
  app.add_option("--fault", o.faults,
                 "reboot:NODE@T: node NODE (a node id, or theta, phi, probe) reboots T s after the start: silent, "
                 "boot-up message, pre-operational until an NMT master starts it; settings-lost:NODE@T: it reboots "
                 "without its stored settings (1017h and 1019h 0, EMCY 0x5000) and cannot be started (repeatable)")
      ->group(f);
  const std::string n = "CANopen nodes";
  app.add_flag("--boot-operational", o.boot_operational,
               "Live: the devices start operational, as if another master had started them (log mode always does)")
      ->group(n);
  app.add_option("--boot-s", o.boot_s, "Power-on or reset to the boot-up message [s]")
      ->check(InRange({0.0, 60.0, "s"}))
      ->group(n);
  app.add_option("--transmission-type", o.transmission_type,
                 "The TPDOs' transmission type after a boot (1: every SYNC; 254: event-driven)")
      ->check(CLI::Range(0, 255))
      ->group(n);
  app.add_option("--nodes-sync-counter-max", o.nodes_sync_counter_max,
                 "The nodes' SYNC counter overflow value (1019h) after a boot; -1: --sync-counter-max. A node whose "
                 "1019h does not fit the SYNC it gets sends EMCY 0x8240 and stays pre-operational")
      ->check(CLI::Range(-1, 240))
      ->group(n);
  app.add_option("--record", o.record_path,
                 "Write what the devices sent for each SYNC: sync_t_s counter theta_deg phi_deg r_mm (- for none)")
      ->group(n);
  app.add_option("--duration-s", o.duration_s, "Live: stop after this long [s]; 0: at the pattern's end")
      ->check(InRange(can::ranges::kRunTimeS))
      ->group(n);
  AddDeviceOptions(app, o.devices, false);
}

can::DeviceSimConfig MakeDeviceSimConfig(const CansimOptions& o) {
  can::DeviceSimConfig c;
  c.spec = ToSimulationSpec(o.machine);
  c.spec.centers_mm = {ParseVector3(o.center_mm, "--center-mm")};
  c.spec.seed = o.seed;
  if (!o.mount_rotation_deg.empty()) {
    c.spec.mount_rotations_deg[0] =
        ParseRotationDeg(o.mount_rotation_deg, "--mount-rotation-deg " + internal::Quoted(o.mount_rotation_deg),
                         "rx,ry,rz (a rotation vector in deg, axis times angle)");
  }
  AddForm(o.form, c.spec.sphere_radius_mm, c.spec.effects);
  c.devices = can::DevicesConfig(o.devices);
  c.sync_period_s = c.devices.sync_period_s;
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
    const std::string what = "--silence '" + s + "'";
    const double from = CheckedValue(ToDouble(p[1], what + ": from_s"), can::ranges::kRunTimeS, what + ": from_s", p[1]);
    const double to = CheckedValue(ToDouble(p[2], what + ": to_s"), can::ranges::kRunTimeS, what + ": to_s", p[2]);
    if (!(from < to)) throw Error(what + ": the window must end after it begins (from_s < to_s)");
    f.silences.push_back({ToDevice(p[0], "--silence"), from, to});
  }
  for (const std::string& s : o.emergencies) {
    const auto p = Split(s, ':');
    if (p.size() != 3) throw Error("--emcy '" + s + "': expected device:at_s:code");
    char* end = nullptr;
    const unsigned long code = std::strtoul(p[2].c_str(), &end, 16);
    if (p[2].empty() || *end != '\0' || code > 0xFFFF) throw Error("--emcy '" + s + "': code must be 16-bit hex");
    const std::string what = "--emcy '" + s + "': at_s";
    const double at = CheckedValue(ToDouble(p[1], what), can::ranges::kRunTimeS, what, p[1]);
    f.emergencies.push_back({ToDevice(p[0], "--emcy"), at, static_cast<std::uint16_t>(code)});
  }
  for (const std::string& s : o.faults) {
    const auto at = s.find('@');
    const bool lost = s.rfind("settings-lost:", 0) == 0;
    if ((s.rfind("reboot:", 0) != 0 && !lost) || at == std::string::npos) {
      throw Error("--fault '" + s +
                  "': expected reboot:NODE@T or settings-lost:NODE@T (NODE a node id or theta, phi, probe; T in s)");
    }
    const std::size_t colon = s.find(':') + 1;
    const std::string node = s.substr(colon, at - colon);
    int id = 0;
    if (node == "theta" || node == "phi" || node == "probe") {
      const int d = ToDevice(node, "--fault");
      id = d == can::kTheta ? c.devices.theta.node_id
           : d == can::kPhi ? c.devices.phi.node_id
                            : c.devices.probe.node_id;
    } else {
      char* end = nullptr;
      const long v = std::strtol(node.c_str(), &end, 10);
      if (node.empty() || *end != '\0' || v < 1 || v > 127) throw Error("--fault '" + s + "': node must be 1..127");
      id = static_cast<int>(v);
    }
    const std::string what = "--fault '" + s + "': T";
    const double t = CheckedValue(ToDouble(s.substr(at + 1), what), can::ranges::kRunTimeS, what, s.substr(at + 1));
    f.reboots.push_back({id, t, lost});
  }
  c.boot_s = o.boot_s;
  c.transmission_type = o.transmission_type;
  if (o.nodes_sync_counter_max == 1) throw Error("--nodes-sync-counter-max: 1 is not allowed (-1, 0 or 2..240)");
  c.sync_counter_overflow = o.nodes_sync_counter_max;
  c.start_operational = o.iface.empty() || o.boot_operational;
  c.Validate();
  const auto points = static_cast<double>(c.spec.pattern.size());
  const double end_s = c.start_time_s + points * c.stop_s + (points - 1.0) * c.move_s;
  if (!(end_s < can::ranges::kEpochTimeS.hi)) {
    throw Error("--start-time-s " + internal::Format("%.0f", c.start_time_s) + ": the simulation would end at " +
                internal::Format("%.0f", end_s) + " s since the epoch, beyond the " +
                internal::Format("%g", can::ranges::kEpochTimeS.hi) + " s that a frame time in ns holds");
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
  can::DeviceSimConfig config;
  try {
    RunPaths paths;
    paths.Input("--config", o.config_path).Input("--angles", o.machine.angles_path);
    paths.Output("--output", o.output_path).Output("--record", o.record_path);
    config = MakeDeviceSimConfig(o);
    if (!o.iface.empty()) config.start_time_s = static_cast<double>(RealtimeNs()) * 1e-9;  // power-on now
    sim.emplace(config);
  } catch (const std::exception& e) {
    err << "sph_cansim: error: " << e.what() << "\n";
    return kExitBadInput;
  }
  sim->set_recording(!o.record_path.empty());
  err << "sph_cansim: " << sim->total_cycles() << " SYNC cycles, " << sim->duration_s() << " s\n";
  OutputFiles files;  // removes what it staged unless committed
  int code = kExitOk;
  if (!o.iface.empty()) {
    code = PlayLive(o, *sim, config, err);
  } else {
    LogTarget target;
    try {
      target = OpenLogTarget(o.output_path, files);
      LogSink sink(target.fd, o.output_path);
      std::vector<can::CanFrame> frames;
      std::string line;
      while (!ProcessControl().stop.load() && sim->NextCycle(frames)) {
        for (const can::CanFrame& fr : frames) {
          line = can::FormatCandumpLine(fr, o.log_iface);
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
    } catch (const std::exception& e) {
      if (target.owned && target.fd >= 0) ::close(target.fd);
      err << "sph_cansim: error: " << e.what() << "\n";
      return kExitOutputError;
    }
    if (const int sig = ProcessControl().stop.load()) {
      err << "sph_cansim: stopped by signal " << sig << ": "
          << (target.staged.empty() ? "the log is incomplete" : "no log written") << "\n";
      return 128 + sig;  // `files` removes the log begun
    }
  }
  PrintInjected(sim->injected(), err);
  try {
    if (!o.record_path.empty())
      files.Stage(o.record_path, [&](std::ostream& out) { WriteRecord(sim->records(), out); });
    files.Commit();
  } catch (const std::exception& e) {
    err << "sph_cansim: error: " << e.what() << "\n";
    return kExitOutputError;
  }
  return code;
}

}  // namespace sph::apps
