#include "acquire_session.hpp"

#include <unistd.h>

#include <cstdio>
#include <ctime>

#include "acquire_internal.hpp"
#include "app_common.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

// Frames kept before the acquisition began (a start takes a few hundred; a SYNC producer at
// 1 kHz adds a thousand a second): beyond this many the oldest are not logged.
constexpr std::size_t kMaxEarlyFrames = 1u << 20;

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

AcquireSession::AcquireSession(const AcquireOptions& options, const can::PipelineConfig& pipeline,
                               can::MasterConfig master, const Logger& log, std::string source, std::string iface)
    : options_(options),
      log_(log),
      pipeline_config_(pipeline),
      source_(std::move(source)),
      iface_(std::move(iface)),
      master_(std::move(master),
              can::CanopenMaster::Callbacks{[this](const can::CanFrame& f) {
                                              if (send_) send_(f);
                                            },
                                            [this](can::LogLevel level, const std::string& text) { log_(level, text); },
                                            [this](const std::string& text) {
                                              if (points_) {
                                                try {
                                                  points_->WriteComment(text);
                                                } catch (const Error& e) {
                                                  throw OutputError(e.what());
                                                }
                                              }
                                            }}) {}

AcquireSession::~AcquireSession() = default;

void AcquireSession::Begin(std::int64_t now_ns) {
  master_.Begin(now_ns);
  Advance(now_ns);
}

void AcquireSession::Advance(std::int64_t now_ns) {
  if (state_ != State::kStarting) return;
  if (master_.phase() == can::CanopenMaster::Phase::kFailed) {
    state_ = State::kStartRefused;
    for (const std::string& e : master_.errors()) log_(can::LogLevel::kError, e);
    log_(can::LogLevel::kError,
         "the start was refused: no points file was made (--trust-config acquires anyway, "
         "--configure-pdo writes the TPDO settings and 1019h)");
    return;
  }
  if (master_.phase() == can::CanopenMaster::Phase::kRunning) StartAcquisition(now_ns);
}

PointsWriterOptions AcquirePointsOptions(const AcquireOptions& o) {
  PointsWriterOptions wo;
  wo.has_time = true;
  wo.has_setup = true;
  wo.fsync_interval_s = o.fsync_interval_s;
  return wo;
}

PointsHeader AcquireHeader(const AcquireOptions& o) {
  PointsHeader header;
  header.sphere_radius_mm = o.sphere_radius_mm;
  header.probe_offset_mm = o.probe_offset_mm;
  if (o.mount_rotation_deg == "unknown") {
    header.mount_rotations[o.setup] = MountRotation::Unknown();
  } else if (!o.mount_rotation_deg.empty()) {
    header.mount_rotations[o.setup] = MountRotation::Known(
        ParseRotationDeg(o.mount_rotation_deg, "--mount-rotation-deg " + internal::Quoted(o.mount_rotation_deg),
                         "rx,ry,rz (a rotation vector in deg, axis times angle) or unknown"));
  }
  if (o.other_sphere_radius_mm) header.sphere_radii_mm[o.setup] = *o.other_sphere_radius_mm;
  return header;
}

// The outputs, opened together: the frame log first (opening writes nothing), then the points
// file, which writes its header. A file this run created is removed again when the other cannot
// be opened, so that a failed start leaves no header-only file behind; a file that was there is
// left as it was (both writers check an existing file before they open it).
bool AcquireSession::OpenOutputs() {
  const AcquireOptions& o = options_;
  const bool points_existed = ::access(o.output_path.c_str(), F_OK) == 0;
  const bool log_existed = o.can_log_path.empty() || ::access(o.can_log_path.c_str(), F_OK) == 0;
  try {
    if (!o.can_log_path.empty()) {
      frame_log_ = std::make_unique<can::CandumpWriter>(o.can_log_path, iface_, o.fsync_interval_s);
    }
    PointsHeader header = AcquireHeader(o);
    header.metadata = {
        {"generator", "sph_acquired " SPH_VERSION}, {"source", source_}, {"mode", o.mode}, {"started", UtcNow()}};
    const auto devices = master_.HeaderFields();
    header.metadata.insert(header.metadata.end(), devices.begin(), devices.end());
    try {
      points_ = std::make_unique<PointsWriter>(o.output_path, header, AcquirePointsOptions(o));
    } catch (const std::exception&) {
      // The header could not be written whole (a full disk): the writer cut it off again.
      if (!points_existed) std::remove(o.output_path.c_str());
      throw;
    }
    if (points_->truncated_bytes() > 0) {
      log_(can::LogLevel::kWarning, o.output_path + ": cut off an incomplete last line of " +
                                        std::to_string(points_->truncated_bytes()) + " bytes left by an earlier run");
    }
    if (points_->resumed()) {
      points_->WriteComment("resumed by sph_acquired " SPH_VERSION " at " + UtcNow() + " (" + o.mode + " mode)");
      for (const auto& [key, value] : devices) points_->WriteComment("devices of this run: " + key + ": " + value);
      log_(can::LogLevel::kInfo, o.output_path + ": continuing the existing file");
    }
  } catch (const std::exception& e) {
    log_(can::LogLevel::kError, e.what());
    try {
      if (points_) points_->Close();
      if (frame_log_) frame_log_->Close();
    } catch (const std::exception&) {  // the first error is the one to report
    }
    if (points_ && !points_existed) std::remove(o.output_path.c_str());
    if (frame_log_ && !log_existed) std::remove(o.can_log_path.c_str());
    points_.reset();
    frame_log_.reset();
    return false;
  }
  return true;
}

void AcquireSession::StartAcquisition(std::int64_t now_ns) {
  if (!OpenOutputs()) {
    state_ = State::kOutputFailed;
    return;
  }
  state_ = State::kAcquiring;
  if (frame_log_) {
    if (early_dropped_ > 0) {
      log_(can::LogLevel::kWarning, "the frame log misses the first " + std::to_string(early_dropped_) +
                                        " frames of the start (more than were kept in memory)");
    }
    try {
      for (const can::CanFrame& f : early_frames_) frame_log_->Write(f);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  }
  early_frames_.clear();
  early_frames_.shrink_to_fit();
  can::AcquisitionPipeline::Callbacks cb;
  cb.sample = [this](const Sample& s) {
    try {
      points_->Write(s);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  };
  cb.note = [this](const std::string& text) {
    try {
      points_->WriteComment(text);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  };
  cb.log = [this](can::LogLevel level, const std::string& text) { log_(level, text); };
  pipeline_ = std::make_unique<can::AcquisitionPipeline>(pipeline_config_, cb);
  pipeline_->OnTime(now_ns);
  log_(can::LogLevel::kInfo, source_ + ": acquiring (" + options_.mode + " mode" +
                                 (master_.config().nmt ? ", the devices started by NMT" : "") + ")");
}

void AcquireSession::OnFrame(const can::CanFrame& received) {
  if (state_ == State::kStartRefused || state_ == State::kOutputFailed) return;
  // The frame log holds microseconds: a live run works on the same times as its replay.
  can::CanFrame frame = received;
  frame.t_ns -= ((frame.t_ns % 1000) + 1000) % 1000;
  if (frame_log_) {
    try {
      frame_log_->Write(frame);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  } else if (state_ == State::kStarting) {
    if (early_frames_.size() < kMaxEarlyFrames) {
      early_frames_.push_back(frame);
    } else {
      ++early_dropped_;
    }
  }
  master_.OnFrame(frame);
  Advance(frame.t_ns);
  if (pipeline_) pipeline_->OnFrame(frame);
}

void AcquireSession::OnTime(std::int64_t now_ns) {
  if (state_ == State::kStartRefused || state_ == State::kOutputFailed) return;
  master_.OnTime(now_ns);
  Advance(now_ns);
  if (pipeline_) pipeline_->OnTime(now_ns);
}

void AcquireSession::OnRxOverflow(std::uint64_t drops, std::int64_t now_ns) {
  if (drops == 0) return;
  if (pipeline_) {
    pipeline_->OnRxOverflow(drops, now_ns);
  } else {
    log_(can::LogLevel::kWarning, "the kernel dropped " + std::to_string(drops) + " received frames during the start");
  }
}

void AcquireSession::OnMalformedInput(const std::string& what) {
  if (pipeline_) {
    pipeline_->OnMalformedInput(what);
  } else {
    log_(can::LogLevel::kWarning, "malformed input: " + what);
  }
}

void AcquireSession::OnLinkEvent(const std::string& what, std::int64_t now_ns) {
  if (pipeline_) pipeline_->OnLinkEvent(what, now_ns);
}

void AcquireSession::FlushOutputs() {
  try {
    if (frame_log_) frame_log_->Flush();
    if (points_) points_->SyncIfDue();
  } catch (const Error& e) {
    throw OutputError(e.what());
  }
}

void AcquireSession::Finish() {
  if (pipeline_) pipeline_->Finish();
  try {
    if (frame_log_) frame_log_->Close();
    if (points_) points_->Close();
  } catch (const Error& e) {
    throw OutputError(e.what());
  }
}

void AcquireSession::Abandon() {
  try {
    if (points_) points_->Close();
  } catch (const std::exception&) {  // already reported the first error
  }
}

std::string AcquireSession::Summary() const {
  std::string s;
  if (pipeline_) {
    s = can::FormatCounts(pipeline_->counts(), pipeline_config_.mode);
  } else {
    s = "no acquisition: the devices were not started";
  }
  const can::CanopenMaster::Counts& m = master_.counts();
  if (master_.config().nmt || master_.config().sdo) {
    s += "\nmaster: NMT commands " + std::to_string(m.nmt_commands) + ", SDO transfers " +
         std::to_string(m.sdo_transfers) + ", reboots " + std::to_string(m.boot_ups) + ", restarted " +
         std::to_string(m.restarts) + ", not restarted " + std::to_string(m.restart_failures) +
         ", started without a heartbeat to confirm it " + std::to_string(m.unconfirmed);
  }
  return s;
}

std::string AcquireSession::OutputSummary() const {
  if (!points_) return "";
  std::string s = options_.output_path + ": " + std::to_string(points_->samples_written()) + " rows written";
  if (frame_log_) s += ", frame log " + std::to_string(frame_log_->frames_written()) + " frames";
  return s;
}

std::uint64_t AcquireSession::Losses() const { return pipeline_ ? pipeline_->counts().Losses() : 0; }

}  // namespace sph::apps
