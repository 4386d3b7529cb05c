#include "gnuplot.hpp"

#include "child_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <utility>

#include "sph/io/cleanup.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {

using internal::Format;

PlotFolder::PlotFolder(std::string dir)
    : dir_(std::move(dir)), existed_(dir_.empty() || ::access(dir_.c_str(), F_OK) == 0) {}

PlotFolder::~PlotFolder() {
  if (!existed_) ::rmdir(dir_.c_str());  // only when empty
}

void PlotFolder::Make() const {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) throw Error(dir_ + ": cannot create the folder: " + ec.message());
}

void GnuplotRun::Set(const std::string& variable, const std::string& file) {
  const std::size_t slash = file.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : file.substr(0, slash == 0 ? 1 : slash);
  struct stat in_dir {};
  struct stat in_folder {};
  if (::stat(dir.c_str(), &in_dir) == 0 && ::stat(folder.c_str(), &in_folder) == 0 &&
      in_dir.st_dev == in_folder.st_dev && in_dir.st_ino == in_folder.st_ino) {
    variables.emplace_back(variable, file.substr(slash + 1));  // npos + 1: the whole name
    return;
  }
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(file, ec);
  if (ec) throw Error(file + ": " + ec.message());
  variables.emplace_back(variable, absolute.string());
}

void GnuplotRun::Draw(const std::string& variable, const std::string& path, OutputFiles& files) {
  const std::string file = files.StageProduced(path);
  Set(variable, file);
  images.emplace_back(path, file);
}

void RunGnuplot(const GnuplotRun& run, const std::string& what) {
  const ScriptFile script(run.folder, run.script, what);
  std::string settings;
  for (const auto& [name, value] : run.variables) settings += name + " = " + GnuplotQuoted(value) + "; ";
  std::vector<std::string> args = {run.program};
  if (!settings.empty()) args.insert(args.end(), {"-e", settings});
  args.push_back(script.name());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(run.timeout_s));
  OutputPipe pipe(what);
  Child child(argv, run.folder, pipe.fd[1], what);
  pipe.CloseWriteEnd();
  std::string output;
  if (!ReadUntilClosed(pipe.fd[0], deadline, output) || !AwaitExit(child.pid(), deadline)) {
    child.Kill();
    throw Error(what + ": gnuplot did not finish " + run.description + " within " + Format("%g", run.timeout_s) +
                " s and was stopped; give it longer with --plot-timeout-s" +
                (output.empty() ? std::string() : " (it printed: " + output + ")"));
  }
  const int status = child.Reap();
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 127) {
    throw Error(what + ": cannot draw " + run.description + ": the program '" + run.program +
                "' was not found; install gnuplot (Debian: apt-get install gnuplot-nox)");
  }
  if (code == 126) throw Error(what + ": cannot enter the folder '" + run.folder + "' to draw " + run.description);
  if (code != 0) {
    throw Error(what + ": gnuplot failed (" +
                (code < 0 ? std::string("killed by a signal") : "exit " + std::to_string(code)) + ")" +
                (output.empty() ? std::string() : ": " + output));
  }
  for (const auto& [path, file] : run.images) {
    struct stat st {};
    if (::stat(file.c_str(), &st) != 0 || st.st_size == 0) {
      throw Error(path + ": gnuplot ended without drawing " + run.description + " into it (the image is empty)" +
                  (output.empty() ? std::string() : ": " + output));
    }
  }
}

}  // namespace sph::apps
