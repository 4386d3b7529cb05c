#include "acquire_cmd.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>

#include "acquire_internal.hpp"
#include "app_common.hpp"

namespace sph::apps {
namespace {

SignalFlags g_signals;

extern "C" void OnStopSignal(int) { g_signals.stop = 1; }
extern "C" void OnSummarySignal(int) { g_signals.summary = 1; }

can::LogLevel ParseLevel(const std::string& text, int verbose) {
  int level = text == "error" ? 0 : text == "warning" ? 1 : text == "info" ? 2 : 3;
  level += verbose;
  return static_cast<can::LogLevel>(level > 3 ? 3 : level);
}

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

SignalFlags& ProcessSignals() { return g_signals; }

void InstallSignalHandlers() {
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking call returns EINTR and the loop sees the flag
  sa.sa_handler = OnStopSignal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  sa.sa_handler = OnSummarySignal;
  sigaction(SIGUSR1, &sa, nullptr);
}

void Logger::operator()(can::LogLevel level, const std::string& text) const {
  if (Enabled(level)) out_ << "sph_acquired: " << can::ToString(level) << ": " << text << "\n" << std::flush;
}

void SetupAcquireApp(CLI::App& app, AcquireOptions& o) {
  app.description("Acquire SCMS samples from CANopen encoders and a probe over SocketCAN (or replay a candump log) "
                  "into an sph-points 1 file, appending record by record.");
  app.option_defaults()->always_capture_default();
  app.set_config("--config", "", "Read options from this file (TOML/INI, 'name = value'; see data/sph_acquired.conf)");
  auto* iface = app.add_option("-i,--iface", o.iface, "CAN interface to acquire from (live)");
  auto* replay = app.add_option("--replay", o.replay_path, "Candump log to replay instead of a live interface")
                     ->excludes(iface);
  iface->excludes(replay);
  app.add_option("-o,--output", o.output_path, "Points file (sph-points 1); appended, never overwritten")->required();
  app.add_option("--can-log", o.can_log_path, "Also append every frame to this candump log");
  app.add_option("--mode", o.mode, "stream: a row per SYNC cycle; points: one averaged row per standstill")
      ->check(CLI::IsMember({"stream", "points"}));
  app.add_option("--setup", o.setup, "Sphere placement id written in the setup column");
  app.add_option("--sphere-radius-mm", o.sphere_radius_mm, "Header: reference sphere radius R0 [mm]")
      ->check(Positive());
  app.add_option("--probe-offset-mm", o.probe_offset_mm, "Header: nominal probe zero distance d [mm]")
      ->check(Positive());
  app.add_option("--fsync-interval-s", o.fsync_interval_s,
                 "fsync the output at most this long after a record [s]; 0: every record; -1: only at the end")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            const bool ok = end != text.c_str() && *end == '\0' && std::isfinite(v) && (v >= 0.0 || v == -1.0);
            return ok ? "" : "must be -1, 0 or a positive number of seconds, got " + text;
          },
          "SECONDS"));
  app.add_option("--sync-mode", o.sync_mode, "produce: send SYNC every --sync-period-ms; follow: an external producer")
      ->check(CLI::IsMember({"produce", "follow"}));
  app.add_option("--heartbeat-timeout-s", o.heartbeat_timeout_s, "A node without heartbeat this long is lost; 0: off")
      ->check(NonNegative());
  app.add_option("--standstill-tol-deg", o.standstill_tol_deg, "Points mode: both axes within this of the stop [deg]")
      ->check(Positive());
  app.add_option("--dwell-s", o.dwell_s, "Points mode: still this long before averaging starts [s]")
      ->check(NonNegative());
  app.add_option("--average-s", o.average_s, "Points mode: averaging time per stop [s]; 0: until the axes move")
      ->check(NonNegative());
  app.add_option("--min-samples", o.min_samples, "Points mode: fewer averaged samples: no point")
      ->check(CLI::Range(1, 100000000));
  app.add_option("--duration-s", o.duration_s, "Live: stop after this long [s]; 0: until SIGTERM/SIGINT")
      ->check(NonNegative());
  app.add_option("--replay-speed", o.replay_speed, "Replay: 1 = the log's own pace; 0: as fast as possible")
      ->check(NonNegative());
  app.add_option("--reopen-interval-s", o.reopen_interval_s, "Live: check this often whether a lost interface is back [s]")
      ->check(Positive());
  app.add_option("--rcvbuf-bytes", o.rcvbuf_bytes, "Live: socket receive buffer (SO_RCVBUF); 0: kernel default")
      ->check(NonNegative());
  app.add_option("--log-level", o.log_level, "error, warning, info or debug")
      ->check(CLI::IsMember({"error", "warning", "info", "debug"}));
  app.add_flag("-v,--verbose", o.verbose, "One log level more (repeatable)");
  AddDeviceOptions(app, o.devices);
}

can::PipelineConfig MakePipelineConfig(const AcquireOptions& o) {
  can::PipelineConfig c;
  ApplyDeviceOptions(o.devices, c);
  c.mode = o.mode == "points" ? can::Mode::kPoints : can::Mode::kStream;
  c.setup = o.setup;
  c.heartbeat_timeout_s = o.heartbeat_timeout_s;
  c.standstill.tolerance_deg = o.standstill_tol_deg;
  c.standstill.dwell_s = o.dwell_s;
  c.standstill.average_s = o.average_s;
  c.standstill.min_samples = o.min_samples;
  c.Validate();
  return c;
}

void AcquireContext::LogFrame(const can::CanFrame& frame) {
  if (frame_log == nullptr) return;
  try {
    frame_log->Write(frame);
  } catch (const Error& e) {
    throw OutputError(e.what());
  }
}

void AcquireContext::FlushOutputs() {
  try {
    if (frame_log != nullptr) frame_log->Flush();
    points.SyncIfDue();
  } catch (const Error& e) {
    throw OutputError(e.what());
  }
}

int RunAcquire(const AcquireOptions& o, std::ostream& err) {
  const Logger log(err, ParseLevel(o.log_level, o.verbose));
  if (o.iface.empty() == o.replay_path.empty()) {
    log(can::LogLevel::kError, "give either --iface (live) or --replay (a candump log)");
    return kExitBadInput;
  }
  can::PipelineConfig config;
  try {
    config = MakePipelineConfig(o);
  } catch (const std::exception& e) {
    log(can::LogLevel::kError, e.what());
    return kExitBadInput;
  }
  if (!o.replay_path.empty()) {
    // Before any output file is made: a log that cannot be read or holds no frame is bad input.
    const std::string problem = CheckReplayLog(o.replay_path);
    if (!problem.empty()) {
      log(can::LogLevel::kError, problem);
      return kExitBadInput;
    }
  }
  std::unique_ptr<PointsWriter> points;
  std::unique_ptr<can::CandumpWriter> frame_log;
  // Files this run creates; removed again when the outputs cannot all be opened, so that a
  // failed start leaves no header-only file behind.
  const bool points_existed = ::access(o.output_path.c_str(), F_OK) == 0;
  const bool log_existed = o.can_log_path.empty() || ::access(o.can_log_path.c_str(), F_OK) == 0;
  try {
    PointsHeader header;
    header.sphere_radius_mm = o.sphere_radius_mm;
    header.probe_offset_mm = o.probe_offset_mm;
    header.metadata = {{"generator", "sph_acquired " SPH_VERSION},
                       {"source", o.iface.empty() ? "replay of " + o.replay_path : "CAN interface " + o.iface},
                       {"mode", o.mode},
                       {"started", UtcNow()}};
    PointsWriterOptions wo;
    wo.has_time = true;
    wo.has_setup = true;
    wo.fsync_interval_s = o.fsync_interval_s;
    points = std::make_unique<PointsWriter>(o.output_path, header, wo);
    if (points->truncated_bytes() > 0) {
      log(can::LogLevel::kWarning, o.output_path + ": cut off an incomplete last line of " +
                                       std::to_string(points->truncated_bytes()) + " bytes left by an earlier run");
    }
    if (points->resumed()) {
      points->WriteComment("resumed by sph_acquired " SPH_VERSION " at " + UtcNow() + " (" + o.mode + " mode)");
      log(can::LogLevel::kInfo, o.output_path + ": continuing the existing file");
    }
    if (!o.can_log_path.empty()) {
      frame_log = std::make_unique<can::CandumpWriter>(o.can_log_path, o.iface.empty() ? "can0" : o.iface,
                                                      o.fsync_interval_s);
    }
  } catch (const std::exception& e) {
    log(can::LogLevel::kError, e.what());
    try {
      if (points) points->Close();
    } catch (const std::exception&) {  // the first error is the one to report
    }
    if (points && !points_existed) std::remove(o.output_path.c_str());
    if (frame_log == nullptr && !log_existed) std::remove(o.can_log_path.c_str());
    return kExitOutputError;
  }

  can::AcquisitionPipeline::Callbacks cb;
  cb.sample = [&](const Sample& s) {
    try {
      points->Write(s);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  };
  cb.note = [&](const std::string& text) {
    try {
      points->WriteComment(text);
    } catch (const Error& e) {
      throw OutputError(e.what());
    }
  };
  cb.log = [&](can::LogLevel level, const std::string& text) { log(level, text); };
  can::AcquisitionPipeline pipeline(config, cb);
  AcquireContext ctx{o, log, pipeline, *points, frame_log.get(), ProcessSignals(), {}};
  ctx.print_summary = [&] {
    err << "sph_acquired: summary: " << can::FormatCounts(pipeline.counts(), config.mode) << "\n"
        << "sph_acquired: summary: " << o.output_path << ": " << points->samples_written() << " rows written"
        << (frame_log ? ", frame log " + std::to_string(frame_log->frames_written()) + " frames" : std::string())
        << "\n" << std::flush;
  };

  int code = kExitOk;
  try {
    code = o.iface.empty() ? RunReplay(ctx) : RunLive(ctx);
    pipeline.Finish();
    if (frame_log) frame_log->Close();
    points->Close();
  } catch (const OutputError& e) {
    log(can::LogLevel::kError, std::string(e.what()) + " (everything written before is intact)");
    try {
      points->Close();
    } catch (const std::exception&) {  // already reported the first error
    }
    ctx.print_summary();
    return kExitOutputError;
  }
  ctx.print_summary();
  if (code != kExitOk) return code;
  const std::uint64_t lost = pipeline.counts().Losses();
  if (lost > 0) {
    log(can::LogLevel::kWarning, "samples were lost: " + std::to_string(lost) + " (see the summary)");
    return kExitSamplesLost;
  }
  return kExitOk;
}

}  // namespace sph::apps
