// libFuzzer target: sph_acquired's --config file (CLI11 config, 'name = value') on arbitrary
// bytes, parsed as the daemon parses it, then turned into the pipeline configuration.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include <CLI/CLI.hpp>

#include "acquire_cmd.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"

namespace {

const std::string& ConfigPath() {
  static const std::string path = [] {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir != nullptr && *dir != '\0' ? dir : "/tmp") + "/sph-fuzz-acquired-" +
           std::to_string(getpid()) + ".conf";
  }();
  static const bool cleanup = [] { return std::atexit([] { std::remove(ConfigPath().c_str()); }) == 0; }();
  (void)cleanup;
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  {
    std::ofstream out(ConfigPath(), std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) std::abort();
  }
  CLI::App app("sph_acquired");
  sph::apps::AcquireOptions options;
  sph::apps::SetupAcquireApp(app, options);
  const std::string config = ConfigPath();
  const char* argv[] = {"sph_acquired", "--config", config.c_str(), "-o", "points.txt"};
  try {
    app.parse(5, argv);
  } catch (const CLI::ParseError&) {
    return 0;
  } catch (const sph::Error&) {  // the file refused at a line (unknown option, given twice, binary)
    return 0;
  }
  try {
    const sph::can::PipelineConfig pc = sph::apps::MakePipelineConfig(options);
    sph::can::AcquisitionPipeline pipeline(pc, {});
    pipeline.OnFrame(sph::can::EncodeSync());
    pipeline.Finish();
  } catch (const sph::Error&) {
  }
  return 0;
}
