// The pipeline's watch on the bus and the devices: error frames, heartbeats, EMCY; the summary.
#include <cstdio>

#include "sph/can/error_frame.hpp"
#include "sph/can/pipeline.hpp"

namespace sph::can {
namespace {

std::string Seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f s", s);
  return buf;
}

}  // namespace

bool AcquisitionPipeline::OnHealthFrame(const CanFrame& frame) {
  if (const auto err = DecodeErrorFrame(frame)) {
    ++counts_.error_frames;
    if ((err->classes & kErrController) != 0 && (frame.data[1] & 0x01) != 0) {
      window_.tainted = true;  // the controller lost received frames
    }
    if (err->bus_off) {
      ++counts_.bus_off;
      Log(LogLevel::kError, "error frame: " + err->text + " (the controller stopped sending and receiving)");
      Note("bus off reported by an error frame at t_s " + std::to_string(frame.TimeS()));
    } else {
      LogLimited(counts_.error_frames, LogLevel::kWarning, [&] { return "error frame: " + err->text; });
    }
    return true;
  }
  if (frame.IsExtended() || frame.IsRemote()) return false;
  const std::uint32_t id = frame.Identifier();
  for (Node& n : nodes_) {
    if (id == kHeartbeatBase + static_cast<std::uint32_t>(n.node_id)) {
      const auto hb = DecodeHeartbeat(frame);
      if (!hb) {
        ++counts_.malformed_other;
        LogLimited(counts_.malformed_other, LogLevel::kWarning, [&] {
          return "malformed heartbeat of node " + std::to_string(n.node_id) + " (" + n.name + "): " + ToString(frame);
        });
        return true;
      }
      if (n.lost) {
        Log(LogLevel::kWarning, "node " + std::to_string(n.node_id) + " (" + n.name + "): heartbeat back after " +
                                    Seconds(static_cast<double>(frame.t_ns - n.last_ns) * 1e-9));
      }
      if (hb->state == static_cast<std::uint8_t>(NmtState::kBootUp)) OnBootUp(n, frame.t_ns);
      const bool was_operational = n.state == static_cast<std::uint8_t>(NmtState::kOperational);
      if (hb->state != n.state || !n.seen) {
        const bool operational = hb->state == static_cast<std::uint8_t>(NmtState::kOperational);
        if (!operational && (was_operational || !n.seen)) ++counts_.not_operational;
        Log(operational ? LogLevel::kInfo : LogLevel::kWarning,
            "node " + std::to_string(n.node_id) + " (" + n.name + "): " + NmtStateName(hb->state));
      }
      n.state = hb->state;
      n.seen = true;
      n.lost = false;
      n.last_ns = frame.t_ns;
      return true;
    }
    if (id == kEmcyBase + static_cast<std::uint32_t>(n.node_id)) {
      const auto e = DecodeEmergency(frame);
      if (!e) {
        ++counts_.malformed_other;
        LogLimited(counts_.malformed_other, LogLevel::kWarning, [&] {
          return "malformed EMCY of node " + std::to_string(n.node_id) + " (" + n.name + "): " + ToString(frame);
        });
        return true;
      }
      ++counts_.emergencies;
      Log(e->error_code == 0 ? LogLevel::kInfo : LogLevel::kWarning, n.name + " " + DescribeEmergency(*e));
      return true;
    }
  }
  return false;
}

void AcquisitionPipeline::OnBootUp(const Node& n, std::int64_t t_ns) {
  ++counts_.reboots;
  const int nodes[] = {config_.theta.node_id, config_.phi.node_id, config_.probe.node_id};
  std::string devices;
  for (int d = 0; d < kNumDevices; ++d) {
    Gap& g = gaps_[static_cast<std::size_t>(d)];
    if (nodes[d] != n.node_id) continue;
    devices += (devices.empty() ? "" : ", ") + std::string(DeviceName(d));
    if (g.open) continue;
    g.open = true;
    g.start_ns = t_ns;
    g.missing_cycles = 0;
  }
  FlushIncomplete();
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6f", static_cast<double>(t_ns) * 1e-9);
  Note("gap start t_s " + std::string(buf) + ": " + n.name + " (node " + std::to_string(n.node_id) +
       ") rebooted (boot-up message): no " + devices + " values until it sends again");
}

void AcquisitionPipeline::CheckHeartbeats(std::int64_t now_ns) {
  if (config_.heartbeat_timeout_s <= 0.0 || start_ns_ == 0) return;
  const auto timeout_ns = static_cast<std::int64_t>(config_.heartbeat_timeout_s * 1e9);
  for (Node& n : nodes_) {
    const std::int64_t since = n.seen ? n.last_ns : start_ns_;
    if (n.lost || now_ns - since <= timeout_ns) continue;
    n.lost = true;
    ++counts_.heartbeats_lost;
    const std::string text =
        "node " + std::to_string(n.node_id) + " (" + n.name + "): heartbeat lost (" +
        (n.seen ? "none for " + Seconds(static_cast<double>(now_ns - since) * 1e-9) : std::string("never seen")) + ")";
    Log(LogLevel::kWarning, text);
  }
}

void AcquisitionPipeline::OnTime(std::int64_t now_ns) {
  if (start_ns_ == 0) start_ns_ = now_ns;
  CheckHeartbeats(now_ns);
}

std::string FormatCounts(const PipelineCounts& c, Mode mode) {
  auto u = [](std::uint64_t v) { return std::to_string(v); };
  std::string s;
  s += "frames " + u(c.frames) + ", SYNC " + u(c.sync_frames) + ", cycles " + u(c.cycles) + ", samples " + u(c.samples);
  if (mode == Mode::kPoints) s += ", points " + u(c.points) + ", short stops " + u(c.short_stops);
  s += "\nlost: incomplete cycles " + u(c.incomplete_cycles) + ", missed SYNC " + u(c.missed_syncs) +
       ", kernel drops (rx overflow) " + u(c.rx_overflow_drops) + "; recovered cycles of missed SYNC " +
       u(c.recovered) + "; last cycle cut by the end " + u(c.cut_by_stop) + "; SYNC counter restarts " +
       u(c.counter_jumps) + ", SYNC received twice " + u(c.repeated_syncs) + ", SYNC counters not usable " +
       u(c.sync_counter_errors);
  s += "\nper device (missing/flagged/malformed): theta " + u(c.missing[kTheta]) + "/" + u(c.flagged[kTheta]) + "/" +
       u(c.malformed[kTheta]) + ", phi " + u(c.missing[kPhi]) + "/" + u(c.flagged[kPhi]) + "/" + u(c.malformed[kPhi]) +
       ", probe " + u(c.missing[kProbe]) + "/" + u(c.flagged[kProbe]) + "/" + u(c.malformed[kProbe]);
  s += "\nbus: error frames " + u(c.error_frames) + " (bus-off " + u(c.bus_off) + "), EMCY " + u(c.emergencies) +
       ", heartbeats lost " + u(c.heartbeats_lost) + ", left operational " + u(c.not_operational) + ", reboots " +
       u(c.reboots) + ", duplicate PDOs " + u(c.duplicates) + ", unplaced PDOs " + u(c.unplaced) +
       ", PDOs before first SYNC " + u(c.outside_cycle) + ", other malformed " + u(c.malformed_other) +
       ", other frames " + u(c.other_frames);
  return s;
}

}  // namespace sph::can
