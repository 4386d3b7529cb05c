// A simulated SCMS on CAN: the Theta and Phi encoders (CiA 406) and the probe measuring a
// reference sphere in a stop-and-go pattern, as CANopen nodes that behave like real ones, with
// faults on demand. The readings come from sph::ProbeReading (sph/core/simulate.hpp), the same
// ray-sphere truth as sph_simulate.
//
// Each device is a node (CiA 301) with an NMT state and an object dictionary served over SDO:
//   1000h device type, 1001h error register, 1008h device name, 1017h producer heartbeat time,
//   1018h identity (vendor-id, product code, revision, serial), 1800h/1A00h + k - 1 the TPDO's
//   communication (COB-ID, transmission type, event timer) and mapping; an encoder 6001h
//   measuring units per revolution, 6002h total measuring range, 6004h position value; the
//   probe 2000h reading [counts], 2001h status; 2010h the counter of the last SYNC (mappable).
// At power-on and after an NMT reset or a reboot fault a node is silent for boot_s, sends its
// boot-up message and is pre-operational: heartbeats, SDO, no PDO. NMT Start makes it
// operational (PDOs), Stop stopped (heartbeats only), Enter pre-operational pre-operational.
// The TPDO's content follows its mapping and its transmission type (1..240: every n-th SYNC;
// 0: on SYNC when the value changed; 254, 255: every event-timer period, without SYNC). PDO
// parameters cannot be written while the node is operational (abort 0x08000022), a COB-ID not
// while the PDO is valid (0x06090030), a mapping entry not while the count is non-zero
// (0x06010000). Log mode (no master) starts the nodes operational.
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
#include "sph/core/gum.hpp"
#include "sph/core/simulate.hpp"

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

/// Node `node_id` reboots (power glitch) at `at_s` after the start.
struct RebootEvent {
  int node_id = 1;
  double at_s = 0.0;
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
  double heartbeat_period_s = 1.0;    ///< 0: no heartbeats (1017h = 0)
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
  std::uint64_t boot_ups = 0;      ///< boot-up messages sent
  std::uint64_t nmt_commands = 0;  ///< NMT commands received
  std::uint64_t sdo_requests = 0;  ///< SDO requests answered (aborts included)
  std::uint64_t sdo_aborts = 0;
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
  void OnSync(std::int64_t t_ns, std::optional<std::uint8_t> counter, std::vector<CanFrame>& out);
  bool TransmitsAtSync(Node& n);
  CanFrame MappedPdo(const Node& n, std::uint64_t cob) const;
  void Boot(Node& n, std::int64_t t_ns);
  static std::uint32_t CheckPdoWrite(const Node& n, ObjectAddress o, const std::vector<std::uint8_t>& v);
  bool Silent(int device, double t_rel_s) const;
  double RelS(std::int64_t t_ns) const;
  std::int64_t GridNs(double at_s, double offset_us) const;

  DeviceSimConfig config_;
  gum::Random rng_;  // the same numbers with every standard library
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
