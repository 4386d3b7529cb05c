// The pipeline's watch on the bus and the devices: error frames, heartbeats, EMCY; the summary.
#include <algorithm>
#include <cstdio>

#include "sph/can/error_frame.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

std::string Seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f s", s);
  return buf;
}

}  // namespace

namespace {

std::string TimeText(std::int64_t t_ns) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6f", static_cast<double>(t_ns) * 1e-9);
  return buf;
}

std::string NodeName(int node_id, const std::string& name) {
  return "node " + std::to_string(node_id) + " (" + name + ")";
}

// The first 20 of a kind, then every 1000th: floods stay readable.
bool Noted(std::uint64_t count) { return count <= 20 || count % 1000 == 0; }

std::string CountSuffix(std::uint64_t count) {
  if (count == 20) return " (further ones: every 1000th is written)";
  return count > 20 ? " (" + std::to_string(count) + " so far)" : "";
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
      NoteAt(frame.t_ns, "bus off reported by an error frame at t_s " + TimeText(frame.t_ns));
    } else {
      LogLimited(counts_.error_frames, LogLevel::kWarning, [&] { return "error frame: " + err->text; });
      if (Noted(counts_.error_frames)) {
        NoteAt(frame.t_ns,
               "error frame t_s " + TimeText(frame.t_ns) + ": " + err->text + CountSuffix(counts_.error_frames));
      }
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
        LogLimited(counts_.malformed_other, LogLevel::kWarning,
                   [&] { return "malformed heartbeat of " + NodeName(n.node_id, n.name) + ": " + ToString(frame); });
        return true;
      }
      OnHeartbeat(n, frame, hb->state);
      return true;
    }
    if (id == kEmcyBase + static_cast<std::uint32_t>(n.node_id)) {
      const auto e = DecodeEmergency(frame);
      if (!e) {
        ++counts_.malformed_other;
        LogLimited(counts_.malformed_other, LogLevel::kWarning,
                   [&] { return "malformed EMCY of " + NodeName(n.node_id, n.name) + ": " + ToString(frame); });
        return true;
      }
      OnEmergency(n, *e, frame.t_ns);
      return true;
    }
  }
  return false;
}

void AcquisitionPipeline::OnHeartbeat(Node& n, const CanFrame& frame, std::uint8_t state) {
  const std::string name = NodeName(n.node_id, n.name);
  if (n.lost) {
    ++counts_.heartbeats_back;
    const std::string text = name + ": heartbeat back after " +
                             Seconds(static_cast<double>(frame.t_ns - n.lost_since_ns) * 1e-9) + " without (" +
                             NmtStateName(state) + ")";
    Log(LogLevel::kWarning, text);
    NoteAt(frame.t_ns, "heartbeat back t_s " + TimeText(frame.t_ns) + ": " + text);
  }
  constexpr auto kOperational = static_cast<std::uint8_t>(NmtState::kOperational);
  constexpr auto kBootUp = static_cast<std::uint8_t>(NmtState::kBootUp);
  if (state == kBootUp) {
    if (n.InError()) EndErrorState(n, frame.t_ns, "it rebooted");
    ++counts_.reboots;
    OpenGaps(n, frame.t_ns, "its reboot", "rebooted (boot-up message)");
  }
  const bool was_operational = n.state == kOperational;
  if (state != n.state || !n.seen) {
    const bool operational = state == kOperational;
    if (!operational && (was_operational || !n.seen)) ++counts_.not_operational;
    Log(operational ? LogLevel::kInfo : LogLevel::kWarning, name + ": " + NmtStateName(state));
    if (state != kBootUp && (n.seen || !operational)) {
      NoteAt(frame.t_ns, "node state t_s " + TimeText(frame.t_ns) + ": " + name + ": " + NmtStateName(state) +
                             (n.seen ? " (was " + NmtStateName(n.state) + ")" : ""));
    }
    if (!operational && state != kBootUp && (was_operational || !n.seen)) {
      OpenGaps(n, frame.t_ns, "it left operational", "left operational (" + NmtStateName(state) + ")");
    }
  }
  n.state = state;
  n.seen = true;
  n.lost = false;
  n.last_ns = frame.t_ns;
}

void AcquisitionPipeline::OnEmergency(Node& n, const Emergency& e, std::int64_t t_ns) {
  ++counts_.emergencies;
  const std::string text = n.name + " " + DescribeEmergency(e);
  Log(e.error_code == 0 ? LogLevel::kInfo : LogLevel::kWarning, text);
  if (Noted(counts_.emergencies)) {
    NoteAt(t_ns, "EMCY t_s " + TimeText(t_ns) + ": " + text + CountSuffix(counts_.emergencies));
  }
  if (e.error_code == 0 || e.error_register == 0) {
    if (n.InError()) EndErrorState(n, t_ns, e.error_code == 0 ? "error reset (EMCY 0x0000)" : "error register 0");
    return;
  }
  if (n.InError()) return;
  n.errors.push_back(std::make_shared<ErrorSpan>(ErrorSpan{t_ns}));
  ++counts_.error_states;
  NoteAt(t_ns, "error state start t_s " + TimeText(t_ns) + ": " + NodeName(n.node_id, n.name) +
                   " signals an error (error register " + internal::Format("0x%02X", e.error_register) +
                   "): the rows until its error state ends come from a device in an error state");
}

void AcquisitionPipeline::EndErrorState(Node& n, std::int64_t t_ns, const std::string& why) {
  const std::shared_ptr<ErrorSpan> span = n.errors.back();
  span->end_ns = t_ns;
  // The rows of the error state are counted as they are written, up to this note's place.
  events_.push_back(PendingNote{t_ns,
                                "error state end t_s " + TimeText(t_ns) + ": " + NodeName(n.node_id, n.name) + ": " +
                                    why + " after " + Seconds(static_cast<double>(t_ns - span->since_ns) * 1e-9),
                                span});
}

void AcquisitionPipeline::RowWritten(std::int64_t t_ns) {
  bool any = false;
  for (Node& n : nodes_) {
    for (const auto& span : n.errors) {
      if (t_ns < span->since_ns || t_ns >= span->end_ns) continue;
      ++span->rows;
      any = true;
    }
    // Error states that ended before this row take no more rows (their notes keep them).
    n.errors.erase(std::remove_if(n.errors.begin(), n.errors.end(),
                                  [t_ns](const std::shared_ptr<ErrorSpan>& s) { return s->end_ns <= t_ns; }),
                   n.errors.end());
  }
  if (any) ++counts_.error_state_rows;
}

void AcquisitionPipeline::NoteAt(std::int64_t t_ns, const std::string& text) {
  // Events come in time order; a row of the cycle open now is written later, after them.
  events_.push_back(PendingNote{t_ns, text, nullptr});
}

void AcquisitionPipeline::AddEvent(std::int64_t t_ns, const std::string& text) { NoteAt(t_ns, text); }

void AcquisitionPipeline::FlushEvents(std::int64_t t_ns) {
  if (events_.empty() || events_.front().t_ns >= t_ns) return;
  FlushIncomplete();  // the incomplete cycles before these events
  std::size_t k = 0;
  for (; k < events_.size() && events_[k].t_ns < t_ns; ++k) {
    const PendingNote& e = events_[k];
    if (!e.span) {
      Note(e.text);
      continue;
    }
    const std::uint64_t rows = e.span->rows;
    Note(e.text + "; " + std::to_string(rows) + (config_.mode == Mode::kPoints ? " point" : " row") +
         (rows == 1 ? "" : "s") + " written in the error state");
  }
  events_.erase(events_.begin(), events_.begin() + static_cast<std::ptrdiff_t>(k));
}

void AcquisitionPipeline::OpenGaps(const Node& n, std::int64_t t_ns, const char* cause, const std::string& what) {
  const int nodes[] = {config_.theta.node_id, config_.phi.node_id, config_.probe.node_id};
  std::string devices;
  bool opened = false;
  for (int d = 0; d < kNumDevices; ++d) {
    Gap& g = gaps_[static_cast<std::size_t>(d)];
    if (nodes[d] != n.node_id) continue;
    devices += (devices.empty() ? "" : ", ") + std::string(DeviceName(d));
    if (g.open) continue;
    opened = true;
    g.open = true;
    g.start_ns = t_ns;
    g.missing_cycles = 0;
    g.cause = cause;
  }
  if (!opened && std::string(cause) != "its reboot") return;  // a gap already open goes on
  NoteAt(t_ns, "gap start t_s " + TimeText(t_ns) + ": " + n.name + " (node " + std::to_string(n.node_id) + ") " + what +
                   ": no " + devices + " values until it sends again");
}

void AcquisitionPipeline::CheckHeartbeats(std::int64_t now_ns) {
  if (config_.heartbeat_timeout_s <= 0.0 || start_ns_ == 0) return;
  const auto timeout_ns = static_cast<std::int64_t>(config_.heartbeat_timeout_s * 1e9);
  for (Node& n : nodes_) {
    const std::int64_t since = n.seen ? n.last_ns : start_ns_;
    if (n.lost || now_ns - since <= timeout_ns) continue;
    n.lost = true;
    n.lost_since_ns = since;
    ++counts_.heartbeats_lost;
    const std::string text = NodeName(n.node_id, n.name) + ": heartbeat lost (" +
                             (n.seen ? "none for " + Seconds(static_cast<double>(now_ns - since) * 1e-9)
                                     : "never seen in " + Seconds(static_cast<double>(now_ns - since) * 1e-9)) +
                             ")";
    Log(LogLevel::kWarning, text);
    NoteAt(now_ns, "heartbeat lost t_s " + TimeText(now_ns) + ": " + text);
  }
}

void AcquisitionPipeline::OnTime(std::int64_t now_ns) {
  if (start_ns_ == 0) start_ns_ = now_ns;
  CheckHeartbeats(now_ns);
}

void AcquisitionPipeline::OnTxQueueFull(const std::string& what, std::int64_t now_ns) {
  ++counts_.tx_queue_full;
  LogLimited(counts_.tx_queue_full, LogLevel::kWarning,
             [&] { return "transmit queue full: a " + what + " was not sent at t_s " + TimeText(now_ns); });
  if (Noted(counts_.tx_queue_full)) {
    NoteAt(now_ns, "transmit queue full t_s " + TimeText(now_ns) + ": a " + what + " was not sent" +
                       CountSuffix(counts_.tx_queue_full));
  }
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
       ", heartbeats lost " + u(c.heartbeats_lost) + " (back " + u(c.heartbeats_back) + "), left operational " +
       u(c.not_operational) + ", reboots " + u(c.reboots) + ", error states " + u(c.error_states) + " (" +
       u(c.error_state_rows) + " rows in them), transmit queue full " + u(c.tx_queue_full) + ", duplicate PDOs " +
       u(c.duplicates) + ", unplaced PDOs " + u(c.unplaced) + ", PDOs before first SYNC " + u(c.outside_cycle) +
       ", other malformed " + u(c.malformed_other) + ", other frames " + u(c.other_frames);
  return s;
}

}  // namespace sph::can
