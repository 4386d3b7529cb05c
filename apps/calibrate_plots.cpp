#include "calibrate_plots.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "gnuplot.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"
#include "sph/select/form_report.hpp"

namespace sph::apps {

using internal::Format;

namespace {

// Stages `script` as <name>.gp in `dir` and runs it by gnuplot on the staged <name>.dat, drawing
// each image (its script variable, its file name without .png) into `dir` through `files`.
void Draw(const std::string& dir, const std::string& name, const std::string& script, const char* description,
          const std::vector<std::pair<std::string, std::string>>& images, double timeout_s, OutputFiles& files) {
  const std::string folder = dir + "/";
  files.Stage(folder + name + ".gp", [&](std::ostream& f) { f << script; });
  GnuplotRun run;  // gnuplot reads the staged data and draws into the staged images
  run.folder = dir;
  run.script = script;
  run.description = description;
  run.timeout_s = timeout_s;
  run.Set("data", files.StagedName(folder + name + ".dat"));
  for (const auto& [variable, image] : images) run.Draw(variable, folder + image + ".png", files);
  RunGnuplot(run, "--plot-dir " + dir);
}

// The residuals of every reading before and after the trace, over theta and phi and against time.
void PlotResiduals(const std::string& dir, const PointsData& points, const CalibrationOptions& options,
                   const TraceResult& r, double timeout_s, OutputFiles& files) {
  const std::string folder = dir + "/";
  // Every reading under each model (outliers too: they show at the end of the colour scale).
  const std::vector<double> before = EffectResiduals(points, options, r.before.fit);
  const std::vector<double> after = EffectResiduals(points, options, r.after.fit);
  files.Stage(folder + "residuals.dat", [&](std::ostream& f) {
    f << "# theta_deg phi_deg t_s residual_before_um residual_after_um\n";
    for (std::size_t i = 0; i < points.samples.size(); ++i) {
      const Sample& s = points.samples[i];
      f << Format("%.6f %.6f %.6f %.6f %.6f\n", s.theta_deg, s.phi_deg, s.t_s, before[i] * kUmPerMm,
                  after[i] * kUmPerMm);
    }
  });
  // The colour scale of the readings the seven-error fit used (at least 1 nm).
  double lim = 1e-3;
  for (double e : r.before.fit.calibration.residuals_mm) lim = std::max(lim, std::abs(e) * kUmPerMm);
  std::string added;
  for (Effect e : r.added) added += (added.empty() ? " + " : ", ") + std::string(InfoOf(e).id);
  std::ostringstream script;
  script << "# Residual plots of sph_calibrate; rerun with: gnuplot residuals.gp (in this folder)\n"
         << "if (!exists(\"data\")) data = 'residuals.dat'\n"
         << "if (!exists(\"map_png\")) map_png = 'residual_map.png'\n"
         << "if (!exists(\"time_png\")) time_png = 'residual_time.png'\n"
         << "set terminal pngcairo size 1400,560 noenhanced font ',11'\n"
         << "set output map_png\n"
         << "set multiplot layout 1,2 title 'Residual |p - O| - R0 [um] over theta and phi'\n"
         << "set xlabel 'theta [deg]'\nset ylabel 'phi [deg]'\nset xrange [0:360]\nset yrange [180:0]\n"
         << "set palette defined (-1 'blue', 0 'white', 1 'red')\n"
         << Format("set cbrange [%.6f:%.6f]\n", -lim, lim) << "set cblabel 'um'\n"
         << Format("set title 'before: seven errors, rms %.4f um'\n", r.before.fit.calibration.rms_um)
         << "plot data using 1:2:4 with points pt 5 ps 2.2 lc palette notitle\n"
         << "set title "
         << GnuplotQuoted(Format("after: seven errors%s, rms %.4f um", added.c_str(), r.after.fit.calibration.rms_um))
         << "\n"
         << "plot data using 1:2:5 with points pt 5 ps 2.2 lc palette notitle\n"
         << "unset multiplot\n"
         << "set output time_png\nset size 1,1\nset autoscale\nset yrange [*:*]\n"
         << "set title 'Residual against acquisition time'\nset xlabel 't [s]'\nset ylabel 'residual [um]'\n"
         << "set key top left\n"
         << "plot data using 3:4 with points pt 7 ps 0.6 lc rgb '#c03030' title 'before', "
            "data using 3:5 with points pt 7 ps 0.6 lc rgb '#3050c0' title 'after'\n";
  Draw(dir, "residuals", script.str(), "the residual plots",
       {{"map_png", "residual_map"}, {"time_png", "residual_time"}}, timeout_s, files);
}

// The sphere's form, when the trace separated it: a map over its body frame.
void PlotSphereForm(const std::string& dir, const TraceResult& r, double timeout_s, OutputFiles& files) {
  const std::string folder = dir + "/";
  const std::vector<SphereFormResult> forms = SphereFormOf(r);
  if (forms.empty()) return;
  const SphereFormResult& form = forms.front();
  const std::vector<std::array<double, 3>> map = FormMap(r.after.fit, 0, 1.0);
  double form_lim = 1e-6;
  for (const auto& row : map) form_lim = std::max(form_lim, std::abs(row[2]));
  files.Stage(folder + "sphere_form.dat", [&](std::ostream& f) {
    f << "# the calibration sphere's form on its body frame: longitude_deg polar_deg form_um\n";
    for (const auto& row : map) f << Format("%.1f %.1f %.6f\n", row[1], row[0], row[2]);
  });
  std::ostringstream form_script;
  form_script << "# The sphere's form map of sph_calibrate; rerun with: gnuplot sphere_form.gp (in this folder)\n"
              << "if (!exists(\"data\")) data = 'sphere_form.dat'\n"
              << "if (!exists(\"png\")) png = 'sphere_form_map.png'\n"
              << "set terminal pngcairo size 1100,600 noenhanced font ',11'\nset output png\n"
              << "set title "
              << GnuplotQuoted(Format("Form of the calibration sphere on its body frame, degrees 2..%d: rms %.4f +- "
                                      "%.4f um, peak to valley %.4f um",
                                      form.degree_max, form.rms_um, form.rms_std_um, form.pv_um))
              << "\n"
              << "set xlabel 'longitude [deg] (from the body x axis)'\nset ylabel 'polar angle [deg] (from the body z "
                 "axis)'\n"
              << "set xrange [0:360]\nset yrange [180:0]\nset palette defined (-1 'blue', 0 'white', 1 'red')\n"
              << Format("set cbrange [%.6f:%.6f]\n", -form_lim, form_lim)
              << "set cblabel 'radial form [um]'\nplot data using 1:2:3 with image notitle\n";
  Draw(dir, "sphere_form", form_script.str(), "the sphere's form map", {{"png", "sphere_form_map"}}, timeout_s, files);
}

// The error curves of the effects of an axis angle, each with its 95 % band, one panel each.
void PlotErrorCurves(const std::string& dir, const TraceResult& r, double timeout_s, OutputFiles& files) {
  if (r.curves.empty()) return;
  const std::string folder = dir + "/";
  files.Stage(folder + "error_curves.dat", [&](std::ostream& f) {
    f << "# the error curves of sph_calibrate, one block each (gnuplot's index), about their mean over the measured "
         "angles\n";
    for (const ErrorCurve& c : r.curves) {
      f << "# " << c.name << " (" << c.iso_name << "): angle_deg value_" << c.unit << " low_" << c.unit << " high_"
        << c.unit << " (the 95 % band: value -+ U95)\n";
      const int steps = std::max(1, static_cast<int>(std::ceil(c.range_hi_deg - c.range_lo_deg)));
      for (int s = 0; s <= steps; ++s) {
        const double a = c.range_lo_deg + (c.range_hi_deg - c.range_lo_deg) * s / steps;
        const double v = c.ValueAt(a), u = c.U95At(a);
        f << Format("%.4f %.6f %.6f %.6f\n", a, v, v - u, v + u);
      }
      f << "\n\n";
    }
  });
  std::ostringstream script;
  script << "# The error curves of sph_calibrate; rerun with: gnuplot error_curves.gp (in this folder)\n"
         << "if (!exists(\"data\")) data = 'error_curves.dat'\n"
         << "if (!exists(\"png\")) png = 'error_curves.png'\n"
         << Format("set terminal pngcairo size 1100,%d noenhanced font ',11'\n", 60 + 300 * static_cast<int>(r.curves.size()))
         << "set output png\n"
         << Format("set multiplot layout %zu,1\n", r.curves.size()) << "set key top right\nset grid\n";
  for (std::size_t i = 0; i < r.curves.size(); ++i) {
    const ErrorCurve& c = r.curves[i];
    script << "set title "
           << GnuplotQuoted(Format("%s (%s): %s %.4g +- %.2g %s", c.name.c_str(), c.iso_name.c_str(),
                                   c.encoder ? "range" : "error motion value", c.pv, c.pv_u95, c.unit.c_str()))
           << "\n"
           << "set xlabel " << GnuplotQuoted(c.variable + " [deg]") << "\n"
           << "set ylabel " << GnuplotQuoted(c.name + " [" + c.unit + "]") << "\n"
           << Format("set xrange [%.4f:%.4f]\n", c.range_lo_deg, c.range_hi_deg)
           << Format("plot data index %zu using 1:3:4 with filledcurves lc rgb '#c8c8c8' title '95 %% band', "
                     "data index %zu using 1:2 with lines lw 2 lc rgb '#000000' title 'curve'\n",
                     i, i);
  }
  script << "unset multiplot\n";
  Draw(dir, "error_curves", script.str(), "the error curves", {{"png", "error_curves"}}, timeout_s, files);
}

}  // namespace

void PlotTrace(const std::string& dir, const PointsData& points, const CalibrationOptions& options,
               const TraceResult& r, double timeout_s, OutputFiles& files) {
  PlotResiduals(dir, points, options, r, timeout_s, files);
  PlotSphereForm(dir, r, timeout_s, files);
  PlotErrorCurves(dir, r, timeout_s, files);
}

}  // namespace sph::apps
