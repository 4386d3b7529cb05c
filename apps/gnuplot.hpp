// The one way the apps draw plots: gnuplot, run without a shell in the folder of the plot, on a
// script written to a temporary file there, with the names of its files passed as variables.
#ifndef SPH_APPS_GNUPLOT_HPP_
#define SPH_APPS_GNUPLOT_HPP_

#include <string>
#include <utility>
#include <vector>

namespace sph::apps {

/// `s` as a gnuplot string in single quotes (a quote is doubled): for names and titles.
std::string GnuplotQuoted(const std::string& s);
/// `s` as a gnuplot string in double quotes, where "\n" is a line break.
std::string GnuplotDoubleQuoted(const std::string& s);

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
};

/// Runs gnuplot; throws sph::Error naming `what` (the file or option the plot is for) with what
/// gnuplot printed when it fails, or saying how to install it when it is not found.
void RunGnuplot(const GnuplotRun& run, const std::string& what);

}  // namespace sph::apps

#endif  // SPH_APPS_GNUPLOT_HPP_
