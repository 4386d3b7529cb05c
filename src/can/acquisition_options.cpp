// The acquisition's options: their checks, and the pipeline's and the master's configuration
// they make.
#include <cstdint>
#include <string>
#include <utility>

#include "sph/can/acquisition.hpp"
#include "sph/can/bus_load.hpp"
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
  CheckedValueOr(o.bitrate_kbit_s, 0.0, "the interface's", ranges::kBitrateKbitS, "--bitrate-kbit-s");
}

int HeartbeatNodes(const PipelineConfig& c) {
  int n = 0;
  for (const int id : {c.theta.node_id, c.phi.node_id, c.probe.node_id}) n += id != 0 ? 1 : 0;
  return n;
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
  PipelineConfig pipeline = AcquisitionPipelineConfig(o);
  if (!o.iface.empty()) CheckBusLoad(o, &pipeline, o.bitrate_kbit_s * 1e3);
}

std::string CheckBusLoad(const AcquisitionOptions& o, PipelineConfig* pipeline, double bitrate_bit_s) {
  if (!(bitrate_bit_s > 0.0)) return "";
  const bool produce = o.sync_mode == SyncMode::kProduce && o.replay_path.empty();
  const int nodes = HeartbeatNodes(*pipeline);
  const double hb_ms = o.no_nmt ? 0.0 : o.node_heartbeat_ms;
  const bool given = o.devices.sync_period_ms && *o.devices.sync_period_ms > 0.0;
  if (produce && !given) pipeline->sync_period_s = DefaultSyncPeriodS(*pipeline, bitrate_bit_s, nodes, hb_ms);
  if (!(pipeline->sync_period_s > 0.0)) return "";
  const BusLoad load = SyncLoad(*pipeline, pipeline->sync_period_s, bitrate_bit_s, nodes, hb_ms);
  const std::string text = DescribeLoad(load, pipeline->sync_period_s, bitrate_bit_s);
  if (load.load > 1.0 && produce) {
    // The shortest period the bus carries: SYNC cycle bits over what the heartbeats leave.
    const double min_ms = 1e3 * load.bits_per_sync / (bitrate_bit_s - load.heartbeat_bits_per_s);
    throw Error("--sync-period-ms " + internal::Format("%g", pipeline->sync_period_s * 1e3) + ": " + text +
                ": the bus cannot carry it; a SYNC period of at least " + internal::Format("%.2f", min_ms) +
                " ms can be carried, " + internal::Format("%.2f", 2.0 * min_ms) +
                " ms or more keeps the load at half the bus or less");
  }
  if (load.load > 0.5) return text + ": more than half the bus (other traffic and retransmissions need room)";
  return "";
}

PipelineConfig AcquisitionPipelineConfig(const AcquisitionOptions& o) {
  CheckedValueOr(o.heartbeat_timeout_s, -1.0, "three of the nodes' heartbeat times", ranges::kTimeoutS,
                 "--heartbeat-timeout-s");
  CheckedValue(o.standstill.tolerance_deg, ranges::kStandstillTolDeg, "--standstill-tol-deg");
  CheckedValue(o.standstill.dwell_s, ranges::kTimeoutS, "--dwell-s");
  CheckedValue(o.standstill.average_s, ranges::kTimeoutS, "--average-s");
  CheckedValue(o.standstill.min_samples, ranges::kMinSamples, "--min-samples");
  PipelineConfig c = DevicesConfig(o.devices);
  // Gap detection: a SYNC of another producer, or of a log, comes at its own period unless given.
  if (!o.devices.sync_period_ms && (!o.replay_path.empty() || o.sync_mode == SyncMode::kFollow)) c.sync_period_s = 0.0;
  c.mode = o.mode;
  c.setup = o.setup;
  c.heartbeat_timeout_s = o.heartbeat_timeout_s < 0.0 ? 0.0 : o.heartbeat_timeout_s;  // -1: set at the start
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
      const ProbeDataType* type = FindProbeDataType(o.devices.probe_data_type);
      if (d.role == "probe" && type != nullptr) {
        d.value_bytes = type->width_bytes;
        d.type_name = "--probe-data-type " + std::string(type->name);
        d.layout_name = "--probe-offset-byte/--probe-data-type";
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
  m.return_timeout_ns = static_cast<std::int64_t>(o.node_return_timeout_s * 1e9);
  m.Validate();
  return m;
}

}  // namespace sph::can
