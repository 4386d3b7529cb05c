// A simulated SCMS on CAN: the Theta and Phi encoders (CiA 406) and the probe measuring a
// reference sphere in a stop-and-go pattern, as CANopen nodes that behave like real ones, with
// faults on demand. The readings come from sph::ProbeReading (sph/simulation/simulate.hpp), the same
// ray-sphere truth as sph_simulate, and a set-up it refuses is refused (CheckSimulationSetup).
//
// Each device is a node (CiA 301) with an NMT state and an object dictionary served over SDO:
//   1000h device type, 1001h error register, 1005h COB-ID SYNC, 1008h device name, 1014h COB-ID
//   EMCY, 1017h producer heartbeat time, 1018h identity (vendor-id, product code, revision,
//   serial), 1019h synchronous counter overflow value, 1800h/1A00h + k - 1 the TPDO's
//   communication (COB-ID, transmission type, event timer) and mapping; an encoder 6001h
//   measuring units per revolution, 6002h total measuring range, 6004h position value; the
//   probe 2000h reading [counts], 2001h status; 2010h the counter of the last SYNC (mappable);
//   2100h a 16-byte location text, read-write (a segmented download; not kept across a reboot).
// 1005h, 1014h, 1017h and 1019h are read-write, as CiA 301 makes them and CANopenNode checks them:
// a node takes SYNC on the id of its 1005h and sends EMCY on that of its 1014h (bit 31: none); a
// written 1017h sends a heartbeat at once and then every new period (0: none); 1019h 1 or above
// 240 is refused (0x06090030). A SYNC whose length is not the one its 1019h says (1 byte with a
// counter, else none) is no SYNC to the node: it sends EMCY 0x8240 (once), sets the communication
// bit of its error register and goes pre-operational. A node with an error in its register does
// not become operational on NMT Start (CANopenNode's default NMT control); a reset clears it. A
// heartbeat also goes out at once whenever the NMT state changes.
// At power-on and after an NMT reset or a reboot fault a node is silent for boot_s, sends its
// boot-up message and is pre-operational: heartbeats, SDO, no PDO. NMT Start makes it
// operational (PDOs), Stop stopped (heartbeats only), Enter pre-operational pre-operational. A
// node that reboots without its stored settings comes back with 1017h and 1019h 0 and an error
// (EMCY 0x5000, device hardware, after its boot-up message), so it stays pre-operational. A node
// can also drop to pre-operational without a reboot (NodeFaultKind), as real ones do after an
// error (1029h) or another master's NMT command.
// The TPDO's content follows its mapping and its transmission type (1..240: every n-th SYNC;
// 0: on SYNC when the value changed; 254, 255: every event-timer period, without SYNC). While the
// node is operational and its PDO valid, only the COB-ID may be written (to make the PDO invalid:
// CiA 301), its other parameters not (abort 0x08000022); a COB-ID's id not while the PDO is valid
// (0x06090030), a mapping entry not while the count is non-zero (0x06010000). Log mode (no master) starts the nodes
// operational.
//
// Timeline: the axes stand at pattern point 0 for stop_s, move to point 1 in move_s (cosine
// velocity profile: u' = (1 - cos(pi u)) / 2), stand for stop_s, and so on; the pattern starts at
// the first SYNC at which every node is operational and advances by one sync_period_s per SYNC
// answered. Internal SYNC k is at start_time_s + k * sync_period_s; each device answers with its
// TPDO 100 us + 130 us * device index after the SYNC (plus up to jitter_us, kept inside the
// cycle). Encoder readings are the axis angle plus Gaussian noise, quantised to counts; the probe
// reads the sphere at the true axis angles plus Gaussian noise.
#ifndef SPH_CAN_DEVICE_SIM_HPP_
#define SPH_CAN_DEVICE_SIM_HPP_

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "sph/can/frame.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/can/sdo.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/stats/random.hpp"

namespace sph::can {

/// A device that sends nothing (no PDO, no heartbeat) from from_s to to_s after the start.
struct Silence {
  int device = kProbe;
  double from_s = 0.0;
  double to_s = 0.0;
};

/// An EMCY frame of `device` at `at_s` after the start.
struct EmcyEvent {
  int device = kProbe;
  double at_s = 0.0;
  std::uint16_t code = 0x5000;
};

/// What happens to a node in a RebootEvent.
enum class NodeFaultKind {
  kReboot,          ///< a power glitch: silent, boot-up message, pre-operational
  kPreOperational,  ///< it enters pre-operational by itself, without a word (no EMCY, no reboot)
  kError,           ///< a communication error (CiA 301 error behaviour, 1029h): EMCY 0x8100 with
                    ///< error register 0x11, pre-operational; cleared clears_after_s later (EMCY
                    ///< 0x0000), after which NMT Start makes it operational again
};

/// Node `node_id` reboots (power glitch), or another NodeFaultKind, at `at_s` after the start.
struct RebootEvent {
  int node_id = 1;
  double at_s = 0.0;
  bool settings_lost = false;  ///< it comes back without its stored settings (see the file comment)
  NodeFaultKind kind = NodeFaultKind::kReboot;
  double clears_after_s = 1.0;  ///< kError: its error clears this long after
};

struct SimFaults {
  double drop_probability = 0.0;                ///< each PDO is lost with this probability
  double short_probability = 0.0;               ///< each PDO loses its last byte (malformed)
  double sync_drop_probability = 0.0;           ///< each SYNC is lost (its cycle's PDOs still follow)
  double probe_out_of_range_probability = 0.0;  ///< the probe sends its over-range code
  double jitter_us = 0.0;                       ///< extra PDO delay, uniform in [0, jitter_us]
  double error_frame_period_s = 0.0;            ///< a controller-problem error frame this often; 0: none
  std::vector<double> bus_off_at_s;             ///< bus-off error frames
  std::vector<Silence> silences;
  std::vector<EmcyEvent> emergencies;
  std::vector<RebootEvent> reboots;
};

struct DeviceSimConfig {
  /// Truth, sphere, pattern, noise; spec.centers_mm[0] is used, with spec.mount_rotations_deg of
  /// setup 0 (if any), the form and the effects on the ray (the probe's own errors, which act on
  /// the reading, are not simulated here).
  SimulationSpec spec;
  PipelineConfig devices;  ///< ids, layouts, scales: what the daemon is configured with
  double sync_period_s = 0.001;
  double move_s = 0.5;                ///< time from one pattern point to the next
  double stop_s = 1.0;                ///< standstill at each pattern point
  double heartbeat_period_s = 1.0;    ///< 1017h after a boot; 0: no heartbeats
  int sync_counter_overflow = -1;     ///< 1019h after a boot (0, 2..240); -1: devices.sync_counter_max
  double start_time_s = 1.7e9;        ///< time of the first SYNC, of power-on [s since the epoch]
  bool start_operational = true;      ///< the nodes start operational (a log without a master)
  double boot_s = 0.05;               ///< power-on or reset to the boot-up message
  double sdo_latency_s = 0.0002;      ///< a node's SDO answer after the request
  int transmission_type = 1;          ///< the TPDOs' transmission type after a boot
  std::uint16_t event_timer_ms = 10;  ///< the TPDOs' event timer after a boot (types 254, 255)
  SimFaults faults;

  /// Throws sph::Error (two devices on one node, a reboot of an unknown node, ...).
  void Validate() const;
};

/// What the simulator did on purpose, to compare with what the pipeline counted.
struct SimInjected {
  std::uint64_t cycles = 0;
  std::uint64_t syncs_dropped = 0;
  std::array<std::uint64_t, kNumDevices> dropped{};
  std::array<std::uint64_t, kNumDevices> shortened{};
  std::array<std::uint64_t, kNumDevices> silent_cycles{};
  std::uint64_t probe_out_of_range = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t emergencies = 0;
  std::uint64_t heartbeats = 0;
  std::uint64_t reboots = 0;       ///< reboot faults
  std::uint64_t state_faults = 0;  ///< nodes dropped to pre-operational without a reboot
  std::uint64_t boot_ups = 0;      ///< boot-up messages sent
  std::uint64_t nmt_commands = 0;  ///< NMT commands received
  std::uint64_t sdo_requests = 0;  ///< SDO requests answered (aborts included)
  std::uint64_t sdo_aborts = 0;
  std::uint64_t sync_length_errors = 0;           ///< SYNCs of another length than a node's 1019h says
  std::array<std::uint64_t, kNumDevices> pdos{};  ///< TPDOs sent
};

/// What the devices sent for one SYNC (for tests and --record): the SYNC time, and per device
/// whether a valid TPDO went out and the value the daemon decodes from it.
struct SimCycleRecord {
  std::int64_t sync_ns = 0;
  std::optional<std::uint8_t> counter;
  std::array<bool, kNumDevices> sent{};
  std::array<double, kNumDevices> value{};
};

class DeviceSimulator {
 public:
  /// Throws sph::Error on a bad configuration (via Validate, PipelineConfig::Validate, ...).
  explicit DeviceSimulator(const DeviceSimConfig& config);
  ~DeviceSimulator();
  DeviceSimulator(const DeviceSimulator&) = delete;
  DeviceSimulator& operator=(const DeviceSimulator&) = delete;

  /// Log mode: the frames up to and with the next internal SYNC's cycle, in time order (SYNC
  /// first unless dropped); false after the last cycle of the pattern.
  bool NextCycle(std::vector<CanFrame>& frames);
  /// A frame the devices receive at frame.t_ns (a SYNC, NMT command or SDO request; others are
  /// ignored): their answers are appended, with their planned sending times, in time order.
  /// Call AdvanceTo(frame.t_ns) first.
  void OnFrame(const CanFrame& frame, std::vector<CanFrame>& out);
  /// What the devices send on their own before `t_ns` (heartbeats, boot-ups, EMCY, error frames,
  /// event-driven PDOs), appended in time order.
  void AdvanceTo(std::int64_t t_ns, std::vector<CanFrame>& out);
  /// When AdvanceTo would next send something (INT64_MAX: never).
  std::int64_t NextEventNs() const;

  /// Whether the pattern is done (every cycle answered).
  bool finished() const { return cycle_ >= total_cycles_; }
  /// Number of SYNC cycles the whole pattern takes.
  std::uint64_t total_cycles() const { return total_cycles_; }
  double duration_s() const;
  const SimInjected& injected() const { return injected_; }
  /// One record per SYNC the devices answered.
  const std::vector<SimCycleRecord>& records() const { return records_; }
  /// Keep records() (off by default: a long run has millions).
  void set_recording(bool on) { recording_ = on; }
  /// The axis angles [deg] at `t_s` after the pattern's start (the trajectory, without noise).
  AnglePair AxesAt(double t_s) const;
  /// The NMT state of a node (0x00 while it is off or booting); 0xFF for an unknown node.
  std::uint8_t NodeState(int node_id) const;

 private:
  struct Node;
  /// A SYNC on `cob_id` at t_ns, to the nodes that take SYNC on that id.
  void OnSync(std::int64_t t_ns, std::uint32_t cob_id, std::optional<std::uint8_t> counter, std::vector<CanFrame>& out);
  /// Whether node n takes a SYNC of this length as one (else: its EMCY 0x8240, pre-operational).
  bool TakesSync(Node& n, std::int64_t t_ns, std::optional<std::uint8_t> counter, std::vector<CanFrame>& out);
  bool TransmitsAtSync(Node& n);
  CanFrame MappedPdo(const Node& n, std::uint64_t cob) const;
  void Boot(Node& n, std::int64_t t_ns);
  /// Node n enters `state` at t_ns (a heartbeat goes out at once when the state changed).
  void Enter(Node& n, NmtState state, std::int64_t t_ns);
  /// Node n's EMCY frame with `code`, or nothing when its 1014h says it sends none.
  std::optional<CanFrame> Emcy(const Node& n, std::uint16_t code, std::uint8_t manufacturer_bit,
                               std::uint32_t info) const;
  /// The abort code of an SDO write of `v` to `o` of node n (0: accepted), as a CiA 301 device checks it.
  static std::uint32_t CheckWrite(const Node& n, ObjectAddress o, const std::vector<std::uint8_t>& v);
  void OnWritten(Node& n, ObjectAddress o);
  bool Silent(int device, double t_rel_s) const;
  /// The time of node n's next reboot fault.
  std::int64_t RebootNs(const Node& n) const;
  double RelS(std::int64_t t_ns) const;
  std::int64_t GridNs(double at_s, double offset_us) const;

  DeviceSimConfig config_;
  std::int64_t now_ns_ = 0;  ///< the time of the frame being taken (for the nodes' side effects)
  Random rng_;               // the same numbers with every standard library
  Eigen::Matrix3d body_to_theta_ = Eigen::Matrix3d::Identity();  // the sphere's mount rotation
  std::vector<std::unique_ptr<Node>> nodes_;
  std::int64_t start_ns_ = 0;
  std::uint64_t cycle_ = 0;
  std::uint64_t total_cycles_ = 0;
  std::uint64_t internal_syncs_ = 0;
  std::uint8_t sync_counter_ = 0;
  bool moving_ = false;
  std::int64_t next_error_frame_ns_ = 0;
  std::uint64_t error_frame_index_ = 1;
  std::vector<bool> bus_off_done_;
  std::vector<bool> emcy_done_;
  SimInjected injected_;
  bool recording_ = false;
  std::vector<SimCycleRecord> records_;
};

}  // namespace sph::can

#endif  // SPH_CAN_DEVICE_SIM_HPP_
