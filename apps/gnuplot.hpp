// The one way the apps draw plots: gnuplot, run without a shell in the folder of the plot, on a
// script written to a temporary file there, with the names of its files passed as variables,
// within a time limit.
#ifndef SPH_APPS_GNUPLOT_HPP_
#define SPH_APPS_GNUPLOT_HPP_

#include <string>
#include <utility>
#include <vector>

#include "sph/io/output_files.hpp"
#include "sph/internal/gnuplot.hpp"

namespace sph::apps {

/// How long one run of gnuplot may take before it is stopped [s] (--plot-timeout-s).
inline constexpr double kDefaultPlotTimeoutS = 60.0;

using internal::GnuplotDoubleQuoted;  // the quoting of the scripts the library renders
using internal::GnuplotQuoted;

/// One run of gnuplot.
struct GnuplotRun {
  std::string program = "gnuplot";
  /// gnuplot runs in this folder: the file names in the script and in `variables` are relative
  /// to it, so that a folder name with spaces or quotes needs no quoting anywhere.
  std::string folder = ".";
  std::string script;                    ///< the whole script
  std::string description = "the plot";  ///< for messages: "cannot draw the form-error map"
  /// Set before the script runs (gnuplot -e "name='value'"); a script uses them with a default,
  /// `if (!exists("name")) name = 'default.png'`, so that it also runs alone.
  std::vector<std::pair<std::string, std::string>> variables;
  /// The images the script draws: the output's name (for messages) and the file gnuplot writes.
  std::vector<std::pair<std::string, std::string>> images;
  double timeout_s = kDefaultPlotTimeoutS;  ///< gnuplot is stopped after this long

  /// Sets `variable` to `file` (a name the run itself uses) as gnuplot sees it from `folder`: its
  /// name alone when it lies in the folder, else its absolute path.
  void Set(const std::string& variable, const std::string& file);
  /// Stages the image `path` (OutputFiles::StageProduced()) and sets `variable` to the file the
  /// script draws it into.
  void Draw(const std::string& variable, const std::string& path, OutputFiles& files);
};

/// The folder a run writes its plots into: made when missing (Make()), and removed again when the
/// run leaves it empty (a run that failed before it put its files in place).
class PlotFolder {
 public:
  explicit PlotFolder(std::string dir);  ///< notes whether `dir` exists; "" is no folder
  ~PlotFolder();
  PlotFolder(const PlotFolder&) = delete;
  PlotFolder& operator=(const PlotFolder&) = delete;
  /// Makes the folder (and its parents) when missing; throws sph::Error naming it.
  void Make() const;

 private:
  std::string dir_;
  bool existed_;
};

/// Runs gnuplot; throws sph::Error naming `what` (the file or option the plot is for) with what
/// gnuplot printed when it fails, saying how to install it when it is not found, when it has
/// not finished within run.timeout_s (it is then killed, with what it started, and waited for),
/// and when it leaves one of run.images empty. A signal that ends the program kills it too
/// (sph/io/cleanup.hpp) before the staged images are removed.
void RunGnuplot(const GnuplotRun& run, const std::string& what);

}  // namespace sph::apps

#endif  // SPH_APPS_GNUPLOT_HPP_
