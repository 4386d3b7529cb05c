// SYNC cycles, PDO decoding, incomplete-cycle accounting, stream and points mode.
#include "sph/can/pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

std::string TimeText(std::int64_t t_ns) { return internal::Format("%.6f", static_cast<double>(t_ns) * 1e-9); }

std::string Hex(std::uint32_t id) { return internal::Format("0x%X", id & ~kEffFlag); }

}  // namespace

const char* DeviceName(int device) {
  switch (device) {
    case kTheta:
      return "theta";
    case kPhi:
      return "phi";
    case kProbe:
      return "probe";
    default:
      return "?";
  }
}

const char* ToString(Mode mode) { return mode == Mode::kPoints ? "points" : "stream"; }

const char* ToString(LogLevel level) {
  switch (level) {
    case LogLevel::kError:
      return "error";
    case LogLevel::kWarning:
      return "warning";
    case LogLevel::kInfo:
      return "info";
    case LogLevel::kDebug:
      return "debug";
  }
  return "?";
}

void PipelineConfig::Validate() const {
  ValidateEncoder(theta, "theta encoder");
  ValidateEncoder(phi, "phi encoder");
  ValidateProbe(probe, "probe");
  const std::uint32_t ids[] = {theta.field.can_id, phi.field.can_id, probe.field.can_id};
  for (int i = 0; i < kNumDevices; ++i) {
    if (ids[i] == sync_cob_id)
      throw Error(std::string(DeviceName(i)) + ": its PDO id " + Hex(ids[i]) + " is the SYNC id");
    for (int j = i + 1; j < kNumDevices; ++j) {
      if (ids[i] == ids[j]) {
        throw Error(std::string(DeviceName(i)) + " and " + DeviceName(j) + " use the same CAN id " + Hex(ids[i]));
      }
    }
  }
  if (sync_counter_max == 1 || sync_counter_max > 240)
    throw Error("the SYNC counter overflow value must be 2..240 (0: none)");
  if (sync_period_s < 0.0 || heartbeat_timeout_s < 0.0) throw Error("periods and timeouts must not be negative");
  const FieldLayout* fields[] = {&theta.field, &phi.field, &probe.field};
  for (int i = 0; i < kNumDevices; ++i) {
    const int b = sync_counter_byte[static_cast<std::size_t>(i)];
    if (b < 0) continue;
    const FieldLayout& f = *fields[i];
    if (b > 7 || (b >= f.offset_byte && b < f.offset_byte + f.width_bytes) ||
        (i == kProbe && b == probe.status_offset_byte)) {
      throw Error(std::string(DeviceName(i)) + ": the SYNC counter byte " + std::to_string(b) +
                  " must be 0..7 and outside the value");
    }
    if (sync_counter_max == 0) {
      throw Error(std::string(DeviceName(i)) + ": a SYNC counter in the PDO needs a SYNC with a counter");
    }
  }
  if (standstill.tolerance_deg <= 0.0 || standstill.dwell_s < 0.0 || standstill.average_s < 0.0) {
    throw Error("standstill: the tolerance must be positive, dwell and averaging times not negative");
  }
}

std::uint64_t PipelineCounts::Losses() const {
  return incomplete_cycles + (missed_syncs - recovered) + rx_overflow_drops;
}

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
  if (config_.sync_counter_max != 0) {
    for (const int b : config_.sync_counter_byte) hold_ |= b >= 0;
  }
}

void AcquisitionPipeline::Log(LogLevel level, const std::string& text) {
  if (cb_.log) cb_.log(level, text);
}

void AcquisitionPipeline::LogCounted(std::uint64_t count, LogLevel level, const std::string& text) {
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
                 [&] { return "malformed SYNC at " + TimeText(frame.t_ns) + ": " + ToString(frame); });
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

double AcquisitionPipeline::PeriodS() const {
  // Configured, else as observed between SYNCs that followed each other.
  return config_.sync_period_s > 0.0 ? config_.sync_period_s : static_cast<double>(observed_period_ns_) * 1e-9;
}

std::optional<std::uint8_t> AcquisitionPipeline::UsableCounter(const CanFrame& frame, const SyncInfo& sync) {
  const int max = config_.sync_counter_max;
  if (max == 0) {
    if (sync.counter && !counter_unconfigured_warned_) {
      counter_unconfigured_warned_ = true;
      Log(LogLevel::kWarning, "the SYNC at t_s " + TimeText(frame.t_ns) + " carries a counter (" +
                                  std::to_string(*sync.counter) +
                                  ") but no SYNC counter is configured: the SYNCs' counters are not used");
    }
    return std::nullopt;
  }
  if (sync.counter && *sync.counter >= 1 && *sync.counter <= max) return sync.counter;
  ++counts_.sync_counter_errors;
  LogLimited(counts_.sync_counter_errors, LogLevel::kWarning, [&] {
    return "the SYNC at t_s " + TimeText(frame.t_ns) +
           (sync.counter ? " carries counter " + std::to_string(*sync.counter) + ", outside 1.." + std::to_string(max) +
                               " (the SYNC counter overflow value)"
                         : " carries no counter (1.." + std::to_string(max) + " expected)") +
           ": its cycle is placed by time";
  });
  return std::nullopt;
}

bool AcquisitionPipeline::Repeats(const CanFrame& frame, const SyncInfo& sync) const {
  if (!have_sync_ || !sync.counter || !last_counter_ || *sync.counter != *last_counter_) return false;
  const double period_s = PeriodS();
  return !(period_s > 0.0) || static_cast<double>(frame.t_ns - last_sync_ns_) < 0.5e9 * period_s;
}

std::uint64_t AcquisitionPipeline::MissedBefore(const CanFrame& frame, const SyncInfo& sync) {
  if (!have_sync_) return 0;
  std::optional<std::uint64_t> by_counter, by_time;
  if (config_.sync_counter_max != 0 && sync.counter && last_counter_) {
    by_counter = static_cast<std::uint64_t>(MissedSyncs(*last_counter_, *sync.counter, config_.sync_counter_max));
  }
  const double period_s = PeriodS();
  const std::int64_t interval_ns = frame.t_ns - last_sync_ns_;
  if (period_s > 0.0) {
    const double gap = static_cast<double>(interval_ns) * 1e-9 / period_s;
    by_time = gap > 1.5 ? static_cast<std::uint64_t>(std::llround(gap)) - 1 : 0;
  }
  std::uint64_t missed = by_counter ? *by_counter : by_time.value_or(0);
  if (by_counter && by_time) {  // the counter's residue, the time's magnitude
    const double m = config_.sync_counter_max;
    const double turns = std::round((static_cast<double>(*by_time) - static_cast<double>(*by_counter)) / m);
    missed = *by_counter + (turns > 0.0 ? static_cast<std::uint64_t>(turns) * config_.sync_counter_max : 0);
    // More SYNCs missed than fit in the time: the producer restarted its counter (as after an
    // NMT reset). A paused producer, whose counter did not move, is the other way round.
    if (missed > *by_time + 1) {
      ++counts_.counter_jumps;
      LogLimited(counts_.counter_jumps, LogLevel::kWarning, [&] {
        return "the SYNC counter went from " + std::to_string(*last_counter_) + " to " + std::to_string(*sync.counter) +
               " in " + TimeText(interval_ns) + " s: a restarted counter, not missed SYNCs";
      });
      missed = *by_time;
    }
  }
  if (missed == 0 && interval_ns > 0) observed_period_ns_ = interval_ns;
  return missed;
}

void AcquisitionPipeline::OnSync(const CanFrame& frame, SyncInfo sync) {
  ++counts_.sync_frames;
  sync.counter = UsableCounter(frame, sync);
  if (Repeats(frame, sync)) {
    ++counts_.repeated_syncs;
    LogLimited(counts_.repeated_syncs, LogLevel::kWarning, [&] {
      return "the SYNC at t_s " + TimeText(frame.t_ns) + " repeats the counter " + std::to_string(*sync.counter) +
             " of the SYNC " + TimeText(frame.t_ns - last_sync_ns_) + " s before: the same SYNC received " +
             "twice, taken once";
    });
    return;
  }
  const std::uint64_t missed = MissedBefore(frame, sync);
  if (hold_) {
    ResolveHeld();
    if (window_.open) {  // held until the next SYNC for its late PDOs
      std::swap(held_, window_);
      held_missed_ = missed;
      held_next_ns_ = frame.t_ns;
    }
  } else {
    Resolve(missed, frame.t_ns);
  }
  have_sync_ = true;
  last_sync_ns_ = frame.t_ns;
  last_counter_ = sync.counter;
  window_.open = true;
  window_.t_ns = frame.t_ns;
  window_.counter = sync.counter;
  window_.tainted = false;
  for (auto& list : window_.pdos) list.clear();
}

void AcquisitionPipeline::OnPdo(int device, const CanFrame& frame) {
  if (!window_.open) {
    ++counts_.outside_cycle;
    LogLimited(counts_.outside_cycle, LogLevel::kDebug, [&] {
      return std::string(DeviceName(device)) + " PDO before the first SYNC at " + TimeText(frame.t_ns);
    });
    return;
  }
  const auto d = static_cast<std::size_t>(device);
  const DecodedValue v = device == kProbe ? DecodeProbe(config_.probe, frame)
                                          : DecodePosition(device == kTheta ? config_.theta : config_.phi, frame);
  if (v.status == DecodeStatus::kShort) {
    ++counts_.malformed[d];
    LogLimited(counts_.malformed[d], LogLevel::kWarning, [&] {
      return std::string("malformed ") + DeviceName(device) + " PDO at " + TimeText(frame.t_ns) + ": " +
             ToString(frame) + " (too short for the configured field)";
    });
  } else if (v.status != DecodeStatus::kOk) {
    ++counts_.flagged[d];
    LogLimited(counts_.flagged[d], LogLevel::kWarning, [&] {
      return std::string(DeviceName(device)) + " reports " + ToString(v.status) + " at " + TimeText(frame.t_ns) +
             " (raw " + std::to_string(v.raw) + ")";
    });
  }
  Arrival a{v.status, v.value, frame.t_ns, -1};
  const int counter_byte = config_.sync_counter_byte[d];
  if (counter_byte >= 0 && frame.len > counter_byte) a.counter = frame.data[static_cast<std::size_t>(counter_byte)];
  Window* w = &window_;
  if (held_.open && a.counter >= 0 && held_.counter) {  // a late PDO of the window before?
    const int m = config_.sync_counter_max;
    const auto k = static_cast<std::uint64_t>(((a.counter - static_cast<int>(*held_.counter)) % m + m) % m);
    if (k <= held_missed_) w = &held_;
  }
  if (w->pdos[d].size() >= kMaxPdosPerWindow) {
    ++counts_.unplaced;
    return;
  }
  w->pdos[d].push_back(a);
}

void AcquisitionPipeline::ResolveHeld() {
  if (!held_.open) return;
  std::swap(window_, held_);  // the resolution works on window_
  Resolve(held_missed_, held_next_ns_);
  std::swap(window_, held_);
}

bool AcquisitionPipeline::Complete(const std::array<Slot, kNumDevices>& slots, const Window& window) {
  for (std::size_t d = 0; d < kNumDevices; ++d) {
    const Slot& s = slots[d];
    if (s.count != 1 || s.lost || window.pdos[d][static_cast<std::size_t>(s.index)].status != DecodeStatus::kOk) {
      return false;
    }
  }
  return true;
}

std::string AcquisitionPipeline::Reason(const std::array<Slot, kNumDevices>& slots) const {
  std::string reason;
  for (int d = 0; d < kNumDevices; ++d) {
    const Slot& s = slots[static_cast<std::size_t>(d)];
    std::string why;
    if (s.count == 0) {
      const Gap& g = gaps_[static_cast<std::size_t>(d)];
      why = !g.open                                ? "no frame"
            : std::string(g.cause) == "its reboot" ? "no frame (rebooted)"
                                                   : "no frame (not operational)";
    } else if (s.lost) {
      why = "frames lost before it";
    } else if (s.count > 1) {
      why = std::to_string(s.count) + " PDOs";
    } else if (const DecodeStatus st =
                   window_.pdos[static_cast<std::size_t>(d)][static_cast<std::size_t>(s.index)].status;
               st != DecodeStatus::kOk) {
      why = ToString(st);
    }
    if (!why.empty()) reason += (reason.empty() ? "" : ", ") + std::string(DeviceName(d)) + " " + why;
  }
  return reason;
}

void AcquisitionPipeline::CloseGaps(const std::array<Slot, kNumDevices>& slots, std::int64_t t_ns) {
  for (int d = 0; d < kNumDevices; ++d) {
    const auto di = static_cast<std::size_t>(d);
    Gap& g = gaps_[di];
    if (!g.open) continue;
    const Slot& s = slots[di];
    // Only a PDO sent after the boot-up ends the gap (one from before it may share the window).
    if (s.count == 0 || window_.pdos[di][static_cast<std::size_t>(s.index)].t_ns < g.start_ns) {
      if (s.count == 0) ++g.missing_cycles;
      continue;
    }
    g.open = false;
    FlushIncomplete();
    const EncoderConfig* e = d == kTheta ? &config_.theta : d == kPhi ? &config_.phi : nullptr;
    const int node = e != nullptr ? e->node_id : config_.probe.node_id;
    const std::string after_s = internal::Format("%.3f", static_cast<double>(t_ns - g.start_ns) * 1e-9);
    const std::uint64_t cycles = g.missing_cycles;
    const std::string text = "gap end t_s " + TimeText(t_ns) + ": " + DeviceName(d) + " (node " + std::to_string(node) +
                             ") sends again, " + after_s + " s after " + g.cause + " (" + std::to_string(cycles) +
                             " SYNC cycle" + (cycles == 1 ? "" : "s") + " without it)";
    Note(text);
    Log(LogLevel::kInfo, text);
  }
}

// Each PDO of the window into the cycle of the SYNC it answers: by its SYNC counter where the
// devices send one, else by its time within the missed SYNCs' periods.
void AcquisitionPipeline::PlaceArrivals(std::uint64_t missed, double period, bool placeable, Cycles& cycles) {
  const auto spans = static_cast<std::uint64_t>(cycles.size());
  for (int d = 0; d < kNumDevices; ++d) {
    const auto di = static_cast<std::size_t>(d);
    const auto& list = window_.pdos[di];
    for (std::size_t j = 0; j < list.size(); ++j) {
      const Arrival& a = list[j];
      std::uint64_t k = 0;
      if (config_.sync_counter_byte[di] >= 0 && a.counter >= 0 && window_.counter && config_.sync_counter_max != 0) {
        const int m = config_.sync_counter_max;
        k = static_cast<std::uint64_t>(((a.counter - static_cast<int>(*window_.counter)) % m + m) % m);
        if (k > missed) {
          ++counts_.unplaced;
          LogLimited(counts_.unplaced, LogLevel::kWarning, [&] {
            return std::string(DeviceName(d)) + " PDO at " + TimeText(a.t_ns) + " answers SYNC counter " +
                   std::to_string(a.counter) + ", not one of the window of counter " +
                   std::to_string(*window_.counter) + " (not used)";
          });
          continue;
        }
      } else if (missed > 0) {
        if (!(period > 0.0)) {  // the SYNCs' times do not advance (a log's): no period to place it in
          ++counts_.unplaced;
          continue;
        }
        const double x = std::floor(static_cast<double>(a.t_ns - window_.t_ns) / period);
        k = x <= 0.0 ? 0 : static_cast<std::uint64_t>(std::min(x, static_cast<double>(missed)));
      }
      if (k >= spans) continue;
      Slot& s = cycles[static_cast<std::size_t>(k)][di];
      if (s.count == 0) s.index = static_cast<int>(j);
      ++s.count;
      if (window_.tainted && !placeable) s.lost = true;
    }
  }
}

// Two or more PDOs of one device in one cycle: none is used, and each extra one is counted.
void AcquisitionPipeline::CountDuplicates(const Cycles& cycles) {
  for (std::size_t k = 0; k < cycles.size(); ++k) {
    for (int d = 0; d < kNumDevices; ++d) {
      const Slot& s = cycles[k][static_cast<std::size_t>(d)];
      if (s.count < 2) continue;
      counts_.duplicates += static_cast<std::uint64_t>(s.count - 1);
      LogLimited(counts_.duplicates, LogLevel::kWarning, [&] {
        return std::to_string(s.count) + " " + DeviceName(d) + " PDOs in the SYNC cycle of t_s " +
               TimeText(window_.t_ns) + ": none is used (one may answer a SYNC that never arrived)";
      });
    }
  }
}

// The cycle of the SYNC received: a sample, or why not.
void AcquisitionPipeline::ResolveReceived(const std::array<Slot, kNumDevices>& slots, bool last) {
  FlushEvents(window_.t_ns);
  CloseGaps(slots, window_.t_ns);
  if (Complete(slots, window_)) {
    EmitCycle(slots, window_.t_ns);
  } else if (last) {
    ++counts_.cut_by_stop;
    FlushIncomplete();
    Note("the SYNC cycle of t_s " + TimeText(window_.t_ns) +
         " was cut by the end of the acquisition (no sample "
         "written)");
  } else {
    ++counts_.incomplete_cycles;
    for (int d = 0; d < kNumDevices; ++d) {
      if (slots[static_cast<std::size_t>(d)].count == 0) ++counts_.missing[static_cast<std::size_t>(d)];
    }
    NoteIncomplete(Reason(slots), window_.t_ns);
  }
}

// The cycles of the `missed` SYNCs that never arrived before the one at `next_ns`: samples where
// their PDOs make one, and a note of them.
void AcquisitionPipeline::ResolveMissed(const Cycles& cycles, std::uint64_t missed, std::int64_t next_ns,
                                        double period) {
  // The cycles of the SYNCs that never arrived.
  counts_.missed_syncs += missed;
  std::uint64_t recovered = 0, with_pdos = 0;
  std::string first_reason;
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    if (Complete(cycles[k], window_)) {
      ++recovered;
      continue;
    }
    bool any = false;
    for (const Slot& s : cycles[k]) any |= s.count > 0;
    if (any) {
      ++with_pdos;
      if (first_reason.empty()) first_reason = Reason(cycles[k]);
    }
  }
  FlushIncomplete();
  std::string text = std::to_string(missed) + " SYNC cycle" + (missed == 1 ? "" : "s") +
                     " missing (never received) between t_s " + TimeText(window_.t_ns) + " and " + TimeText(next_ns);
  if (recovered > 0) text += "; " + std::to_string(recovered) + " recovered from their PDOs (t_s interpolated)";
  if (with_pdos > 0) {
    text += "; " + std::to_string(with_pdos) + " with PDOs but no sample: " + first_reason;
  }
  Note(text);
  Log(LogLevel::kWarning, text);
  counts_.recovered += recovered;
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    const auto t = window_.t_ns + static_cast<std::int64_t>(std::llround(period * static_cast<double>(k)));
    FlushEvents(t);
    CloseGaps(cycles[k], t);
    if (Complete(cycles[k], window_)) EmitCycle(cycles[k], t);
  }
}

void AcquisitionPipeline::Resolve(std::uint64_t missed, std::int64_t next_ns, bool last) {
  if (!window_.open) return;
  window_.open = false;
  counts_.cycles += 1 + missed;
  const std::uint64_t spans = std::min<std::uint64_t>(missed, kMaxRecovered) + 1;
  const double period = static_cast<double>(next_ns - window_.t_ns) / static_cast<double>(missed + 1);
  const bool placeable = config_.sync_period_s > 0.0 || (config_.sync_counter_max != 0 && window_.counter);
  std::vector<std::array<Slot, kNumDevices>>& cycles = scratch_;  // reused: no allocation per SYNC
  cycles.assign(static_cast<std::size_t>(spans), std::array<Slot, kNumDevices>{});
  PlaceArrivals(missed, period, placeable, cycles);
  CountDuplicates(cycles);
  ResolveReceived(cycles[0], last);
  if (missed > 0) ResolveMissed(cycles, missed, next_ns, period);
}

void AcquisitionPipeline::EmitCycle(const std::array<Slot, kNumDevices>& slots, std::int64_t t_ns) {
  ++counts_.samples;
  FlushIncomplete();
  std::array<double, kNumDevices> v{};
  for (int d = 0; d < kNumDevices; ++d) {
    const auto di = static_cast<std::size_t>(d);
    v[di] = window_.pdos[di][static_cast<std::size_t>(slots[di].index)].value;
  }
  Sample s;
  s.theta_deg = v[kTheta];
  s.phi_deg = v[kPhi];
  s.r_mm = v[kProbe];
  s.t_s = static_cast<double>(t_ns) * 1e-9;
  s.setup = config_.setup;
  if (!stops_) {
    RowWritten(t_ns);
    if (cb_.sample) cb_.sample(s);
    return;
  }
  if (const auto p = stops_->Add(s, t_ns)) EmitPoint(*p);
  counts_.short_stops = static_cast<std::uint64_t>(stops_->short_stops());
}

void AcquisitionPipeline::EmitPoint(const StopPoint& p) {
  ++counts_.points;
  RowWritten(static_cast<std::int64_t>(std::llround(p.mean.t_s * 1e9)));
  if (cb_.sample) cb_.sample(p.mean);
  Note(internal::Format(
      "scatter of the point above: n %d, sd theta %.3f arcsec, sd phi %.3f arcsec, sd r %.4f um, over %.3f s", p.n,
      p.sd_theta_deg * 3600.0, p.sd_phi_deg * 3600.0, p.sd_r_mm * 1000.0, p.duration_s));
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
  window_.tainted = true;  // the drops were among the frames since the last one read
  const std::string text = "the kernel dropped " + std::to_string(drops) +
                           " received frames (socket receive queue overflow) before t_s " + TimeText(now_ns);
  Note(text);
  Log(LogLevel::kWarning, text);
}

void AcquisitionPipeline::OnMalformedInput(const std::string& what) {
  ++counts_.malformed_other;
  LogLimited(counts_.malformed_other, LogLevel::kWarning, [&] { return "malformed input: " + what; });
}

void AcquisitionPipeline::OnLinkEvent(const std::string& what, std::int64_t now_ns) {
  ResolveHeld();
  Resolve(0, now_ns, false);
  FlushIncomplete();
  have_sync_ = false;  // the gap while the link was down is noted here, not as missed SYNCs
  FlushEvents(now_ns + 1);
  Note(what + " at t_s " + TimeText(now_ns));
}

void AcquisitionPipeline::Finish() {
  ResolveHeld();
  Resolve(0, window_.t_ns, true);
  FlushIncomplete();
  if (stops_) {
    if (const auto p = stops_->Finish()) EmitPoint(*p);
    counts_.short_stops = static_cast<std::uint64_t>(stops_->short_stops());
  }
  FlushEvents(std::numeric_limits<std::int64_t>::max());
  for (const Node& n : nodes_) {
    if (!n.InError()) continue;
    const std::uint64_t rows = n.errors.back()->rows;
    Note("the error state of node " + std::to_string(n.node_id) + " (" + n.name + "), since t_s " +
         TimeText(n.errors.back()->since_ns) + ", lasted to the end: " + std::to_string(rows) +
         (config_.mode == Mode::kPoints ? " point" : " row") + (rows == 1 ? "" : "s") + " written in it");
  }
}

}  // namespace sph::can
