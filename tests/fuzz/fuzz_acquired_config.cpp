// libFuzzer target: sph_acquired's --config file (CLI11 config, 'name = value') on arbitrary
// bytes, read as the daemon reads its file (the strict line checks of UseStrictConfig, then CLI11's
// values and the options' checks) but from memory, then turned into the pipeline and master
// configurations by the library. The CLI app is made once and reset for each input: making it
// anew per input, with a temporary file to read, took most of the time.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

#include "acquire_cmd.hpp"
#include "sph/can/acquisition.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"

namespace {

struct Daemon {
  CLI::App app{"sph_acquired"};
  sph::apps::AcquireOptions options;
  Daemon() {
    sph::apps::SetupAcquireApp(app, options);
    app.get_option("--output")->required(false);  // given on the command line, not in the file
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Daemon daemon;
  daemon.options = sph::apps::AcquireOptions{};  // the app's options point into it
  daemon.app.clear();
  std::istringstream config(std::string(reinterpret_cast<const char*>(data), size));
  try {
    daemon.app.parse_from_stream(config);
  } catch (const CLI::ParseError&) {
    return 0;
  } catch (const sph::Error&) {  // the file refused at a line (unknown option, given twice, binary)
    return 0;
  }
  try {
    const sph::can::PipelineConfig pc = sph::can::AcquisitionPipelineConfig(daemon.options.acq);
    (void)sph::can::AcquisitionMasterConfig(daemon.options.acq, pc);
    sph::can::AcquisitionPipeline pipeline(pc, {});
    pipeline.OnFrame(sph::can::EncodeSync());
    pipeline.Finish();
  } catch (const sph::Error&) {
  }
  return 0;
}
