// SYNC cycles, PDO decoding, incomplete-cycle accounting, stream and points mode.
#include "sph/can/pipeline.hpp"

#include <cmath>
#include <cstdio>
#include <set>

#include "sph/core/error.hpp"

namespace sph::can {
namespace {

std::string TimeText(std::int64_t t_ns) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6f", static_cast<double>(t_ns) * 1e-9);
  return buf;
}

std::string Hex(std::uint32_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%X", id & ~kEffFlag);
  return buf;
}

}  // namespace

const char* DeviceName(int device) {
  switch (device) {
    case kTheta: return "theta";
    case kPhi: return "phi";
    case kProbe: return "probe";
    default: return "?";
  }
}

const char* ToString(LogLevel level) {
  switch (level) {
    case LogLevel::kError: return "error";
    case LogLevel::kWarning: return "warning";
    case LogLevel::kInfo: return "info";
    case LogLevel::kDebug: return "debug";
  }
  return "?";
}

void PipelineConfig::Validate() const {
  ValidateEncoder(theta, "theta encoder");
  ValidateEncoder(phi, "phi encoder");
  ValidateProbe(probe, "probe");
  const std::uint32_t ids[] = {theta.field.can_id, phi.field.can_id, probe.field.can_id};
  for (int i = 0; i < kNumDevices; ++i) {
    if (ids[i] == sync_cob_id) throw Error(std::string(DeviceName(i)) + ": its PDO id " + Hex(ids[i]) + " is the SYNC id");
    for (int j = i + 1; j < kNumDevices; ++j) {
      if (ids[i] == ids[j]) {
        throw Error(std::string(DeviceName(i)) + " and " + DeviceName(j) + " use the same CAN id " + Hex(ids[i]));
      }
    }
  }
  if (sync_counter_max == 1 || sync_counter_max > 240) throw Error("the SYNC counter overflow value must be 2..240 (0: none)");
  if (sync_period_s < 0.0 || heartbeat_timeout_s < 0.0) throw Error("periods and timeouts must not be negative");
  if (standstill.tolerance_deg <= 0.0 || standstill.dwell_s < 0.0 || standstill.average_s < 0.0) {
    throw Error("standstill: the tolerance must be positive, dwell and averaging times not negative");
  }
}

std::uint64_t PipelineCounts::Losses() const { return incomplete_cycles + missed_syncs + rx_overflow_drops; }

AcquisitionPipeline::AcquisitionPipeline(const PipelineConfig& config, Callbacks callbacks)
    : config_(config), cb_(std::move(callbacks)) {
  config_.Validate();
  const std::pair<int, const char*> devices[] = {
      {config_.theta.node_id, "theta"}, {config_.phi.node_id, "phi"}, {config_.probe.node_id, "probe"}};
  std::set<int> seen;
  for (const auto& [id, name] : devices) {
    if (id == 0) continue;
    if (!seen.insert(id).second) {
      for (Node& n : nodes_) {
        if (n.node_id == id) n.name += std::string("+") + name;
      }
      continue;
    }
    Node n;
    n.node_id = id;
    n.name = name;
    nodes_.push_back(n);
  }
  if (config_.mode == Mode::kPoints) stops_.emplace(config_.standstill);
}

void AcquisitionPipeline::Log(LogLevel level, const std::string& text) {
  if (cb_.log) cb_.log(level, text);
}

void AcquisitionPipeline::LogLimited(std::uint64_t count, LogLevel level, const std::string& text) {
  if (count <= 20) {
    Log(level, text + (count == 20 ? " (further ones: every 1000th is logged)" : ""));
  } else if (count % 1000 == 0) {
    Log(level, text + " (" + std::to_string(count) + " so far)");
  }
}

void AcquisitionPipeline::Note(const std::string& text) {
  if (cb_.note) cb_.note(text);
}

void AcquisitionPipeline::OnFrame(const CanFrame& frame) {
  ++counts_.frames;
  if (start_ns_ == 0) start_ns_ = frame.t_ns;
  if (OnHealthFrame(frame)) {
    CheckHeartbeats(frame.t_ns);
    return;
  }
  if (frame.id == config_.sync_cob_id) {
    if (const auto sync = DecodeSync(frame, config_.sync_cob_id)) {
      OnSync(frame, *sync);
    } else {
      ++counts_.malformed_other;
      LogLimited(counts_.malformed_other, LogLevel::kWarning,
                 "malformed SYNC at " + TimeText(frame.t_ns) + ": " + ToString(frame));
    }
  } else if (frame.id == config_.theta.field.can_id) {
    OnPdo(kTheta, frame);
  } else if (frame.id == config_.phi.field.can_id) {
    OnPdo(kPhi, frame);
  } else if (frame.id == config_.probe.field.can_id) {
    OnPdo(kProbe, frame);
  } else {
    ++counts_.other_frames;
  }
  CheckHeartbeats(frame.t_ns);
}

void AcquisitionPipeline::OnSync(const CanFrame& frame, const SyncInfo& sync) {
  ++counts_.sync_frames;
  CloseCycle();
  std::uint64_t missed = 0;
  if (have_sync_) {
    if (config_.sync_counter_max != 0 && sync.counter && last_counter_) {
      missed = static_cast<std::uint64_t>(MissedSyncs(*last_counter_, *sync.counter, config_.sync_counter_max));
    } else if (config_.sync_period_s > 0.0) {
      const double gap = static_cast<double>(frame.t_ns - last_sync_ns_) * 1e-9 / config_.sync_period_s;
      if (gap > 1.5) missed = static_cast<std::uint64_t>(std::llround(gap)) - 1;
    }
  }
  if (missed > 0) {
    FlushIncomplete();
    counts_.missed_syncs += missed;
    const std::string text = std::to_string(missed) + " SYNC cycle" + (missed == 1 ? "" : "s") +
                             " missing (never received) between t_s " + TimeText(last_sync_ns_) + " and " +
                             TimeText(frame.t_ns);
    Note(text);
    Log(LogLevel::kWarning, text);
  }
  have_sync_ = true;
  last_sync_ns_ = frame.t_ns;
  last_counter_ = sync.counter;
  cycle_ = Cycle{};
  cycle_.open = true;
  cycle_.t_ns = frame.t_ns;
}

void AcquisitionPipeline::OnPdo(int device, const CanFrame& frame) {
  if (!cycle_.open) {
    ++counts_.outside_cycle;
    LogLimited(counts_.outside_cycle, LogLevel::kDebug,
               std::string(DeviceName(device)) + " PDO before the first SYNC at " + TimeText(frame.t_ns));
    return;
  }
  const auto d = static_cast<std::size_t>(device);
  if (cycle_.seen[d]) {
    ++counts_.duplicates;
    LogLimited(counts_.duplicates, LogLevel::kWarning,
               std::string("second ") + DeviceName(device) + " PDO in the SYNC cycle of t_s " + TimeText(cycle_.t_ns) +
                   " (the first one is kept)");
    return;
  }
  cycle_.seen[d] = true;
  const DecodedValue v = device == kProbe ? DecodeProbe(config_.probe, frame)
                                          : DecodePosition(device == kTheta ? config_.theta : config_.phi, frame);
  cycle_.status[d] = v.status;
  cycle_.value[d] = v.value;
  if (v.status == DecodeStatus::kShort) {
    ++counts_.malformed[d];
    LogLimited(counts_.malformed[d], LogLevel::kWarning,
               std::string("malformed ") + DeviceName(device) + " PDO at " + TimeText(frame.t_ns) + ": " +
                   ToString(frame) + " (too short for the configured field)");
  } else if (v.status != DecodeStatus::kOk) {
    ++counts_.flagged[d];
    LogLimited(counts_.flagged[d], LogLevel::kWarning,
               std::string(DeviceName(device)) + " reports " + ToString(v.status) + " at " + TimeText(frame.t_ns) +
                   " (raw " + std::to_string(v.raw) + ")");
  }
  if (!cycle_.emitted && cycle_.seen[kTheta] && cycle_.seen[kPhi] && cycle_.seen[kProbe] &&
      cycle_.status[kTheta] == DecodeStatus::kOk && cycle_.status[kPhi] == DecodeStatus::kOk &&
      cycle_.status[kProbe] == DecodeStatus::kOk) {
    EmitSample();
  }
}

void AcquisitionPipeline::EmitSample() {
  cycle_.emitted = true;
  ++counts_.samples;
  FlushIncomplete();
  Sample s;
  s.theta_deg = cycle_.value[kTheta];
  s.phi_deg = cycle_.value[kPhi];
  s.r_mm = cycle_.value[kProbe];
  s.t_s = static_cast<double>(cycle_.t_ns) * 1e-9;
  s.setup = config_.setup;
  if (!stops_) {
    if (cb_.sample) cb_.sample(s);
    return;
  }
  if (const auto p = stops_->Add(s)) EmitPoint(*p);
  counts_.short_stops = static_cast<std::uint64_t>(stops_->short_stops());
}

void AcquisitionPipeline::EmitPoint(const StopPoint& p) {
  ++counts_.points;
  if (cb_.sample) cb_.sample(p.mean);
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "scatter of the point above: n %d, sd theta %.3f arcsec, sd phi %.3f arcsec, sd r %.4f um, over %.3f s",
                p.n, p.sd_theta_deg * 3600.0, p.sd_phi_deg * 3600.0, p.sd_r_mm * 1000.0, p.duration_s);
  Note(buf);
}

void AcquisitionPipeline::CloseCycle() {
  if (!cycle_.open) return;
  cycle_.open = false;
  ++counts_.cycles;
  if (cycle_.emitted) return;
  ++counts_.incomplete_cycles;
  std::string reason;
  for (int d = 0; d < kNumDevices; ++d) {
    const auto i = static_cast<std::size_t>(d);
    std::string why;
    if (!cycle_.seen[i]) {
      ++counts_.missing[i];
      why = "no frame";
    } else if (cycle_.status[i] != DecodeStatus::kOk) {
      why = ToString(cycle_.status[i]);
    }
    if (!why.empty()) reason += (reason.empty() ? "" : ", ") + std::string(DeviceName(d)) + " " + why;
  }
  NoteIncomplete(reason, cycle_.t_ns);
}

void AcquisitionPipeline::NoteIncomplete(const std::string& reason, std::int64_t t_ns) {
  if (run_.cycles > 0 && (run_.reason != reason || t_ns - run_.first_ns >= 10'000'000'000LL)) FlushIncomplete();
  if (run_.cycles == 0) {
    run_.first_ns = t_ns;
    run_.reason = reason;
  }
  run_.last_ns = t_ns;
  ++run_.cycles;
}

void AcquisitionPipeline::FlushIncomplete() {
  if (run_.cycles == 0) return;
  const std::string text = std::to_string(run_.cycles) + " incomplete SYNC cycle" + (run_.cycles == 1 ? "" : "s") +
                           " from t_s " + TimeText(run_.first_ns) + " to " + TimeText(run_.last_ns) +
                           " (no sample written): " + run_.reason;
  Note(text);
  Log(LogLevel::kWarning, text);
  run_ = IncompleteRun{};
}

void AcquisitionPipeline::OnRxOverflow(std::uint64_t drops, std::int64_t now_ns) {
  if (drops == 0) return;
  counts_.rx_overflow_drops += drops;
  const std::string text = "the kernel dropped " + std::to_string(drops) +
                           " received frames (socket receive queue overflow) before t_s " + TimeText(now_ns);
  Note(text);
  Log(LogLevel::kWarning, text);
}

void AcquisitionPipeline::OnMalformedInput(const std::string& what) {
  ++counts_.malformed_other;
  LogLimited(counts_.malformed_other, LogLevel::kWarning, "malformed input: " + what);
}

void AcquisitionPipeline::OnLinkEvent(const std::string& what, std::int64_t now_ns) {
  CloseCycle();
  FlushIncomplete();
  have_sync_ = false;  // the gap while the link was down is noted here, not as missed SYNCs
  Note(what + " at t_s " + TimeText(now_ns));
}

void AcquisitionPipeline::Finish(bool stopped) {
  if (stopped && cycle_.open && !cycle_.emitted) {
    cycle_.open = false;
    ++counts_.cut_by_stop;
    FlushIncomplete();
    Note("the SYNC cycle of t_s " + TimeText(cycle_.t_ns) + " was cut by the stop (no sample written)");
  }
  CloseCycle();
  FlushIncomplete();
  if (stops_) {
    if (const auto p = stops_->Finish()) EmitPoint(*p);
    counts_.short_stops = static_cast<std::uint64_t>(stops_->short_stops());
  }
}

}  // namespace sph::can
