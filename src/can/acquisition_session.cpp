#include "sph/can/acquisition_session.hpp"

#include <unistd.h>

#include <cstdio>
#include <ctime>

#include "sph/internal/format.hpp"

namespace sph::can {
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

std::string Generator(const AcquisitionOptions& o) {
  return o.generator.empty() ? std::string("sph_acquired " SPH_VERSION) : o.generator;
}

}  // namespace

AcquisitionSession::AcquisitionSession(const AcquisitionOptions& options, const PipelineConfig& pipeline,
                                       MasterConfig master, Log log, std::string source, std::string iface)
    : options_(options),
      log_(log ? std::move(log) : [](LogLevel, const std::string&) {}),
      pipeline_config_(pipeline),
      source_(std::move(source)),
      iface_(std::move(iface)),
      master_(std::move(master),
              CanopenMaster::Callbacks{[this](const CanFrame& f) {
                                         if (send_) send_(f);
                                       },
                                       [this](LogLevel level, const std::string& text) { log_(level, text); },
                                       [this](const std::string& text) {
                                         // At its place among the rows (the pipeline writes it).
                                         if (pipeline_) pipeline_->AddEvent(now_ns_, text);
                                       }}) {}

AcquisitionSession::~AcquisitionSession() = default;

void AcquisitionSession::Begin(std::int64_t now_ns) {
  master_.Begin(now_ns);
  Advance(now_ns);
}

void AcquisitionSession::Advance(std::int64_t now_ns) {
  if (state_ == State::kAcquiring && master_.phase() == CanopenMaster::Phase::kNodeLost) {
    state_ = State::kNodeLost;
    for (const std::string& e : master_.errors()) error_ += (error_.empty() ? "" : "\n") + e;
    log_(LogLevel::kError, "the acquisition ends: a node did not come back");
    return;
  }
  if (state_ != State::kStarting) return;
  if (master_.phase() == CanopenMaster::Phase::kFailed) {
    state_ = State::kStartRefused;
    const std::string refused =
        "the start was refused: no points file was made (--trust-config acquires anyway, "
        "--configure-pdo writes the TPDO settings and 1019h)";
    for (const std::string& e : master_.errors()) {
      log_(LogLevel::kError, e);
      error_ += e + "\n";
    }
    log_(LogLevel::kError, refused);
    error_ += refused;
    UndoStart();
    return;
  }
  if (master_.phase() == CanopenMaster::Phase::kRunning) StartAcquisition(now_ns);
}

PointsWriterOptions AcquisitionPointsOptions(const AcquisitionOptions& o) {
  PointsWriterOptions wo;
  wo.has_time = true;
  wo.has_setup = true;
  wo.fsync_interval_s = o.fsync_interval_s;
  return wo;
}

PointsHeader AcquisitionHeader(const AcquisitionOptions& o) {
  PointsHeader header;
  header.sphere_radius_mm = o.sphere_radius_mm;
  header.probe_offset_mm = o.probe_offset_mm;
  if (o.mount_rotation) header.mount_rotations[o.setup] = *o.mount_rotation;
  if (o.other_sphere_radius_mm) header.sphere_radii_mm[o.setup] = *o.other_sphere_radius_mm;
  return header;
}

// The outputs, opened together: the frame log first (opening writes nothing), then the points
// file, which writes its header. A file this run created is removed again when the other cannot
// be opened, so that a failed start leaves no header-only file behind; a file that was there is
// left as it was (both writers check an existing file before they open it).
bool AcquisitionSession::OpenOutputs() {
  const AcquisitionOptions& o = options_;
  const bool points_existed = ::access(o.output_path.c_str(), F_OK) == 0;
  const bool log_existed = o.can_log_path.empty() || ::access(o.can_log_path.c_str(), F_OK) == 0;
  try {
    if (!o.can_log_path.empty()) {
      frame_log_ = std::make_unique<CandumpWriter>(o.can_log_path, iface_, o.fsync_interval_s);
    }
    PointsHeader header = AcquisitionHeader(o);
    header.metadata = {
        {"generator", Generator(o)}, {"source", source_}, {"mode", ToString(o.mode)}, {"started", UtcNow()}};
    const auto devices = master_.HeaderFields();
    header.metadata.insert(header.metadata.end(), devices.begin(), devices.end());
    try {
      points_ = std::make_unique<PointsWriter>(o.output_path, header, AcquisitionPointsOptions(o));
    } catch (const std::exception&) {
      // The header could not be written whole (a full disk): the writer cut it off again.
      if (!points_existed) std::remove(o.output_path.c_str());
      throw;
    }
    if (points_->truncated_bytes() > 0) {
      Warn(o.output_path + ": cut off an incomplete last line of " + std::to_string(points_->truncated_bytes()) +
           " bytes left by an earlier run");
    }
    if (points_->resumed()) {
      points_->WriteComment("resumed by " + Generator(o) + " at " + UtcNow() + " (" + ToString(o.mode) + " mode)");
      for (const auto& [key, value] : devices) points_->WriteComment("devices of this run: " + key + ": " + value);
      log_(LogLevel::kInfo, o.output_path + ": continuing the existing file");
    }
  } catch (const std::exception& e) {
    error_ = e.what();
    log_(LogLevel::kError, error_);
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

void AcquisitionSession::StartAcquisition(std::int64_t now_ns) {
  if (!OpenOutputs()) {
    state_ = State::kOutputFailed;
    return;
  }
  state_ = State::kAcquiring;
  if (frame_log_) {
    if (early_dropped_ > 0) {
      Warn("the frame log misses the first " + std::to_string(early_dropped_) +
           " frames of the start (more than were kept in memory)");
    }
    try {
      for (const CanFrame& f : early_frames_) frame_log_->Write(f);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  }
  early_frames_.clear();
  early_frames_.shrink_to_fit();
  AcquisitionPipeline::Callbacks cb;
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
  cb.log = [this](LogLevel level, const std::string& text) { log_(level, text); };
  // Heartbeat consumer: by default three of the longest producer time the master found or set.
  if (options_.heartbeat_timeout_s < 0.0 && master_.LongestHeartbeatMs() > 0) {
    pipeline_config_.heartbeat_timeout_s = 3e-3 * master_.LongestHeartbeatMs();
    log_(LogLevel::kInfo, "heartbeats watched: a node silent for " +
                              internal::Format("%g", pipeline_config_.heartbeat_timeout_s) +
                              " s (three of the longest producer heartbeat time) is lost");
  }
  pipeline_ = std::make_unique<AcquisitionPipeline>(pipeline_config_, cb);
  pipeline_->OnTime(now_ns);
  // Started by NMT without SDO: a node that is not there is started without a word.
  const bool unconfirmed_start = master_.config().nmt && !master_.config().sdo;
  for (const std::string& node : unconfirmed_start ? master_.NeverHeard() : std::vector<std::string>{}) {
    const std::string text = node +
                             " has not been heard from since the start (no heartbeat, EMCY, SDO answer or "
                             "PDO): started without a word from it";
    log_(LogLevel::kWarning, text);
    pipeline_->AddEvent(now_ns, text);
  }
  log_(LogLevel::kInfo, source_ + ": acquiring (" + ToString(options_.mode) + " mode" +
                            (master_.config().nmt ? ", the devices started by NMT" : "") + ")");
}

void AcquisitionSession::OnFrame(const CanFrame& received) {
  if (ended()) return;
  // The frame log holds microseconds: a live run works on the same times as its replay.
  CanFrame frame = received;
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
  now_ns_ = frame.t_ns;
  master_.OnFrame(frame);
  Advance(frame.t_ns);
  if (pipeline_) pipeline_->OnFrame(frame);
}

void AcquisitionSession::OnTime(std::int64_t now_ns) {
  if (ended()) return;
  now_ns_ = now_ns;
  master_.OnTime(now_ns);
  Advance(now_ns);
  if (pipeline_) pipeline_->OnTime(now_ns);
}

void AcquisitionSession::OnRxOverflow(std::uint64_t drops, std::int64_t now_ns) {
  if (drops == 0) return;
  if (pipeline_) {
    pipeline_->OnRxOverflow(drops, now_ns);
  } else {
    log_(LogLevel::kWarning, "the kernel dropped " + std::to_string(drops) + " received frames during the start");
  }
}

void AcquisitionSession::OnMalformedInput(const std::string& what) {
  if (pipeline_) {
    pipeline_->OnMalformedInput(what);
  } else {
    log_(LogLevel::kWarning, "malformed input: " + what);
  }
}

void AcquisitionSession::OnTxQueueFull(const std::string& what, std::int64_t now_ns) {
  if (pipeline_) {
    pipeline_->OnTxQueueFull(what, now_ns);
  } else {
    log_(LogLevel::kWarning, "transmit queue full: a " + what + " was not sent during the start");
  }
}

void AcquisitionSession::OnLinkEvent(const std::string& what, std::int64_t now_ns) {
  if (pipeline_) pipeline_->OnLinkEvent(what, now_ns);
}

void AcquisitionSession::FlushOutputs() {
  try {
    if (frame_log_) frame_log_->Flush();
    if (points_) points_->SyncIfDue();
  } catch (const Error& e) {
    throw OutputError(e.what());
  }
}

void AcquisitionSession::Finish() {
  if (pipeline_) {
    for (const std::string& node : master_.NeverHeard()) {
      pipeline_->AddEvent(now_ns_, node + " was never heard from during the run (no frame of it at all)");
    }
    pipeline_->Finish();
  }
  try {
    if (frame_log_) frame_log_->Close();
    if (points_) points_->Close();
  } catch (const Error& e) {
    throw OutputError(e.what());
  }
}

void AcquisitionSession::UndoStart() {
  const std::vector<CanFrame> frames = master_.UndoStart();
  if (frames.empty() || !send_) return;
  std::string sent;
  for (const CanFrame& f : frames) {
    send_(f);
    sent += (sent.empty() ? "" : " ") + ToString(f);
  }
  log_(LogLevel::kInfo,
       "leaving the bus as the start found it (the nodes started back to their state, 1017h "
       "written back): " +
           sent);
}

void AcquisitionSession::Abandon() {
  try {
    if (points_) points_->Close();
  } catch (const std::exception&) {  // already reported the first error
  }
}

AcquisitionResult AcquisitionSession::Result() const {
  AcquisitionResult r;
  r.ran = true;
  r.acquired = pipeline_ != nullptr;
  if (pipeline_) r.counts = pipeline_->counts();
  r.mode = pipeline_config_.mode;
  r.master_used = master_.config().nmt || master_.config().sdo;
  r.master = master_.counts();
  r.outputs_opened = points_ != nullptr;
  r.output_path = options_.output_path;
  if (points_) r.rows_written = points_->samples_written();
  r.frame_log = frame_log_ != nullptr;
  if (frame_log_) r.frames_logged = frame_log_->frames_written();
  r.losses = Losses();
  if (pipeline_) r.never_heard = master_.NeverHeard();
  r.warnings = warnings_;
  return r;
}

std::uint64_t AcquisitionSession::Losses() const { return pipeline_ ? pipeline_->counts().Losses() : 0; }

void AcquisitionSession::Warn(const std::string& text) {
  warnings_.push_back(text);
  log_(LogLevel::kWarning, text);
}

}  // namespace sph::can
