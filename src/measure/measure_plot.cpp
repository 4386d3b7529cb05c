#include <algorithm>
#include <cmath>
#include <sstream>

#include "sph/measure/measure_workflow.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/gnuplot.hpp"
#include "sph/model/units.hpp"

namespace sph {

using internal::Format;
using internal::GnuplotDoubleQuoted;
using internal::GnuplotQuoted;

std::string MeasurementWorkflowResult::FormMapScript(const std::string& png_path) const {
  const std::vector<Eigen::Vector3d>& points = input.points_mm;
  const SphereEvaluation& ev = evaluation;
  const std::string name = points_path.substr(points_path.find_last_of('/') + 1);
  const bool cap = ev.coverage.cap_half_angle_deg <= 135.0;
  const Eigen::Vector3d e3 = cap ? ev.coverage.mean_direction : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d ref = std::abs(e3.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = (ref - ref.dot(e3) * e3).normalized();
  const Eigen::Vector3d e2 = e3.cross(e1);
  double max_abs_um = 0.0, max_polar_deg = 0.0;
  std::ostringstream data;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d v = (points[i] - ev.ls.sphere.center).normalized();
    const double polar = std::acos(std::clamp(v.dot(e3), -1.0, 1.0)) * kDegPerRad;
    double azimuth = std::atan2(v.dot(e2), v.dot(e1)) * kDegPerRad;
    if (azimuth < 0.0) azimuth += 360.0;
    const double res_um = ev.residuals_mm[i] * kUmPerMm;
    max_abs_um = std::max(max_abs_um, std::abs(res_um));
    max_polar_deg = std::max(max_polar_deg, polar);
    data << Format("%.4f %.4f %.6g\n", azimuth, polar, res_um);
  }
  if (!(max_abs_um > 0.0)) max_abs_um = 1e-6;
  const double y_max = std::min(180.0, 15.0 * std::ceil(max_polar_deg / 15.0 + 1e-9));
  const double point_size = std::clamp(2.4 * std::sqrt(300.0 / static_cast<double>(points.size())), 0.35, 2.4);

  std::ostringstream s;
  s << "# Form-error map written by " << Program() << ". Run: gnuplot <this file>\n"
    << "# Radial residuals about the least-squares sphere; data inline (azimuth_deg polar_deg residual_um).\n"
    << "set encoding utf8\n"
    << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
    << "  set terminal pngcairo size 1200,680 enhanced font 'sans,11'\n"
    << "} else {\n"
    << "  set terminal png size 1200,680\n"
    << "}\n"
    << "if (!exists(\"png\")) png = " << GnuplotQuoted(png_path) << "\n"
    << "set output png\n";
  const std::string title = Format(
      "Form error of %s (%d points): radial residual about the least-squares sphere, R = %.6f mm\n"
      "sphericity: least squares %.4f µm, minimum zone %.4f µm",
      name.c_str(), ev.n_points, ev.ls.sphere.radius, ev.sphericity_ls_mm * kUmPerMm, ev.mz.width * kUmPerMm);
  s << "set title " << GnuplotDoubleQuoted(title) << " noenhanced\n";
  s << "set xlabel "
    << GnuplotQuoted(cap ? "azimuth about the cap's centre [deg]" : "azimuth about the z (Θ) axis [deg]") << "\n";
  s << "set ylabel " << GnuplotQuoted(cap ? "angle from the cap's centre [deg]" : "polar angle from +z [deg]") << "\n";
  s << "set cblabel 'radial residual [µm]'\n"
    << "set xrange [0:360]\nset xtics 0,45,360\n";
  s << Format("set yrange [%g:0]\nset ytics 0,15,%g\n", y_max, y_max);
  s << Format("set cbrange [%.6g:%.6g]\n", -max_abs_um, max_abs_um)
    << "set palette defined (0 '#2166ac', 0.25 '#67a9cf', 0.5 '#f7f7f7', 0.75 '#ef8a62', 1 '#b2182b')\n"
    << "set object 1 rectangle from graph 0,0 to graph 1,1 behind fillcolor rgb '#d9d9d9' fillstyle solid noborder\n"
    << "set grid front lc rgb '#ffffff'\nunset key\n"
    << "$residuals << EOD\n"
    << data.str() << "EOD\n";
  s << Format("plot $residuals using 1:2:3 with points pt 5 ps %.2f lc palette\n", point_size);
  return s.str();
}

}  // namespace sph
