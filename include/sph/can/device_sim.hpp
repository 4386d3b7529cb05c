// A simulated SCMS on CAN: the Theta and Phi encoders (CiA 406) and the probe measuring a
// reference sphere in a stop-and-go pattern, as CANopen traffic (SYNC, TPDOs, heartbeats), with
// faults on demand. The readings come from sph::ProbeReading (sph/core/simulate.hpp), the same
// ray-sphere truth as sph_simulate.
//
// Timeline: the axes stand at pattern point 0 for stop_s, move to point 1 in move_s (cosine
// velocity profile: u' = (1 - cos(pi u)) / 2), stand for stop_s, and so on. Cycle k starts at
//   t_k = start_time_s + k * sync_period_s
// with the SYNC; each device answers with its TPDO 100 us + 130 us * device index after it (plus
// up to jitter_us, kept inside the cycle). Encoder readings are the axis angle plus Gaussian noise,
// quantised to counts; the probe reads the sphere at the true axis angles plus Gaussian noise.
#ifndef SPH_CAN_DEVICE_SIM_HPP_
#define SPH_CAN_DEVICE_SIM_HPP_

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "sph/can/frame.hpp"
#include "sph/can/pipeline.hpp"
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

struct SimFaults {
  double drop_probability = 0.0;       ///< each PDO is lost with this probability
  double short_probability = 0.0;      ///< each PDO loses its last byte (malformed)
  double sync_drop_probability = 0.0;  ///< each SYNC is lost (its cycle's PDOs still follow)
  double probe_out_of_range_probability = 0.0;  ///< the probe sends its over-range code
  double jitter_us = 0.0;              ///< extra PDO delay, uniform in [0, jitter_us]
  double error_frame_period_s = 0.0;   ///< a controller-problem error frame this often; 0: none
  std::vector<double> bus_off_at_s;    ///< bus-off error frames
  std::vector<Silence> silences;
  std::vector<EmcyEvent> emergencies;
};

struct DeviceSimConfig {
  SimulationSpec spec;              ///< truth, sphere, pattern, noise (spec.centers_mm[0] is used)
  PipelineConfig devices;           ///< ids, layouts, scales: what the daemon is configured with
  double sync_period_s = 0.001;
  double move_s = 0.5;              ///< time from one pattern point to the next
  double stop_s = 1.0;              ///< standstill at each pattern point
  double heartbeat_period_s = 1.0;  ///< 0: no heartbeats
  double start_time_s = 1.7e9;      ///< time of the first SYNC [s since the epoch]
  SimFaults faults;
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
};

class DeviceSimulator {
 public:
  /// Throws sph::Error on a bad configuration (via PipelineConfig::Validate, empty pattern, ...).
  explicit DeviceSimulator(const DeviceSimConfig& config);

  /// The frames of the next cycle in time order (SYNC first unless dropped); false after the
  /// last cycle of the pattern.
  bool NextCycle(std::vector<CanFrame>& frames);
  /// The devices' answer to a SYNC received at `t_ns` (external SYNC producer); false after the
  /// pattern's end. Frame times are the planned sending times.
  bool AnswerSync(std::int64_t t_ns, std::vector<CanFrame>& frames);

  /// Number of SYNC cycles the whole pattern takes.
  std::uint64_t total_cycles() const { return total_cycles_; }
  double duration_s() const;
  const SimInjected& injected() const { return injected_; }
  /// The axis angles [deg] at `t_s` after the start (the trajectory, without noise).
  AnglePair AxesAt(double t_s) const;

 private:
  void AppendCycle(std::int64_t t_ns, double t_rel_s, bool with_sync, std::vector<CanFrame>& frames);
  bool Silent(int device, double t_rel_s) const;

  DeviceSimConfig config_;
  std::mt19937_64 rng_;
  std::uint64_t cycle_ = 0;
  std::uint64_t total_cycles_ = 0;
  std::uint8_t sync_counter_ = 0;
  double next_heartbeat_s_ = 0.0;
  double next_error_frame_s_ = 0.0;
  std::vector<bool> bus_off_done_;
  std::vector<bool> emcy_done_;
  SimInjected injected_;
};

}  // namespace sph::can

#endif  // SPH_CAN_DEVICE_SIM_HPP_
