// The acquisition's options: their checks, and the pipeline's and the master's configuration
// they make.
#include <cstdint>
#include <string>
#include <utility>

#include "sph/can/acquisition.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

// The numbers of the run and its outputs (the pipeline's and the master's are checked where
// their configurations are made).
void CheckRunNumbers(const AcquisitionOptions& o) {
  CheckedValueOr(o.fsync_interval_s, -1.0, "only at the end", ranges::kFsyncIntervalS, "--fsync-interval-s");
  if (o.sphere_radius_mm) CheckedValue(*o.sphere_radius_mm, ranges::kSphereRadiusMm, "--sphere-radius-mm");
  if (o.probe_offset_mm) CheckedValue(*o.probe_offset_mm, ranges::kProbeOffsetMm, "--probe-offset-mm");
  if (o.other_sphere_radius_mm) {
    CheckedValue(*o.other_sphere_radius_mm, ranges::kSphereRadiusMm, "--other-sphere-radius-mm");
  }
  if (o.mount_rotation && o.mount_rotation->known() && !o.mount_rotation->rotation_deg->allFinite()) {
    throw Error("--mount-rotation-deg: the rotation vector must be finite");
  }
  CheckedValue(o.duration_s, ranges::kRunTimeS, "--duration-s");
  CheckedValue(o.replay_speed, ranges::kReplaySpeed, "--replay-speed");
  CheckedValue(o.reopen_interval_s, ranges::kReopenIntervalS, "--reopen-interval-s");
  CheckedValue(o.rcvbuf_bytes, ranges::kRcvbufBytes, "--rcvbuf-bytes");
}

void CheckMasterFlags(const AcquisitionOptions& o) {
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
  CheckedValue(o.node_heartbeat_ms, ranges::kNodeHeartbeatMs, "--node-heartbeat-ms");
  CheckedValue(o.sdo_timeout_ms, ranges::kSdoTimeoutMs, "--sdo-timeout-ms");
  CheckedValue(o.boot_timeout_s, ranges::kBootTimeoutS, "--boot-timeout-s");
  CheckedValue(o.node_return_timeout_s, ranges::kNodeReturnTimeoutS, "--node-return-timeout-s");
}

}  // namespace

void CheckAcquisitionOptions(const AcquisitionOptions& o) {
  if (o.iface.empty() == o.replay_path.empty()) throw Error("give either --iface (live) or --replay (a candump log)");
  if (!o.replay_iface.empty() && o.replay_path.empty()) {
    throw Error("--replay-iface " + o.replay_iface + ": names the interface of a replay (--replay)");
  }
  AcquisitionMasterConfig(o, AcquisitionPipelineConfig(o));
  CheckRunNumbers(o);
}

PipelineConfig AcquisitionPipelineConfig(const AcquisitionOptions& o) {
  CheckedValue(o.heartbeat_timeout_s, ranges::kTimeoutS, "--heartbeat-timeout-s");
  CheckedValue(o.standstill.tolerance_deg, ranges::kStandstillTolDeg, "--standstill-tol-deg");
  CheckedValue(o.standstill.dwell_s, ranges::kTimeoutS, "--dwell-s");
  CheckedValue(o.standstill.average_s, ranges::kTimeoutS, "--average-s");
  CheckedValue(o.standstill.min_samples, ranges::kMinSamples, "--min-samples");
  PipelineConfig c = DevicesConfig(o.devices);
  // Gap detection: a SYNC of another producer, or of a log, comes at its own period unless given.
  if (!o.devices.sync_period_ms && (!o.replay_path.empty() || o.sync_mode == SyncMode::kFollow)) c.sync_period_s = 0.0;
  c.mode = o.mode;
  c.setup = o.setup;
  c.heartbeat_timeout_s = o.heartbeat_timeout_s;
  c.standstill = o.standstill;
  c.Validate();
  return c;
}

MasterConfig AcquisitionMasterConfig(const AcquisitionOptions& o, const PipelineConfig& pc) {
  CheckMasterFlags(o);
  MasterConfig m;
  m.nodes = MasterNodesFor(pc);
  for (MasterNode& n : m.nodes) {
    for (MasterDevice& d : n.devices) {
      d.cpr_name = "--" + d.role + "-counts-per-rev";
      d.cob_name = "--" + d.role + "-cob-id";
      d.layout_name = "--" + d.role + "-offset-byte/--" + d.role + "-width-bytes";
      if (d.role == "probe" && o.probe_pdo_object) d.mapped_object = *o.probe_pdo_object;
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
  m.return_timeout_ns = static_cast<std::int64_t>(o.node_return_timeout_s * 1e9);
  m.Validate();
  return m;
}

}  // namespace sph::can
