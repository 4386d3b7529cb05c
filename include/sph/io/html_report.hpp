// The pieces of sph's HTML reports: escaping, a self-contained page with its screen and print
// style (A4, the major sections on a new page, tables that wrap instead of being clipped), tables, and
// figures as SVG held in the page itself. Nothing a page made here holds refers to another file
// or the network.
#ifndef SPH_IO_HTML_REPORT_HPP_
#define SPH_IO_HTML_REPORT_HPP_

#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace sph::html {

/// `text` with & < > " ' replaced by their character references: safe as element text and as
/// an attribute value. Every text that comes from an input file goes through it.
std::string Escape(std::string_view text);

/// A number as the reports print it: 6 significant digits ("0.0199524", "-1.23e-07"); "-" for
/// NaN or infinity.
std::string Number(double value);

/// "2026-12-04 23:16 UTC": now, as the reports date themselves.
std::string UtcNow();

/// A number with `decimals` digits after the point ("20.000000"); "-" for NaN or infinity.
std::string Fixed(double value, int decimals);

/// A whole HTML document: `title` (escaped) and `body` (HTML as given), with the style sheet.
std::string Page(const std::string& title, const std::string& body);

/// A figure: the SVG document `svg` embedded in the page as an <img> of a data: URL (the page's
/// own bytes; an HTML 4 parser such as xmllint --html reads it as well as a browser), with its
/// alternative text and caption (both escaped).
std::string Figure(const std::string& svg, const std::string& alt, const std::string& caption);

/// Whether a section starts a new page in print.
enum class NewPage { kYes, kNo };

/// A section of the report: its title (escaped) and body (HTML as given), from a new page in print
/// or after what precedes it.
std::string Section(const std::string& title, const std::string& body, NewPage new_page = NewPage::kYes);

/// Figures side by side on a wide page (each a Figure()), one under the other on a narrow one.
std::string FigureRow(const std::vector<std::string>& figures);

/// A table: the header cells and the rows, each cell HTML as given (escape text first).
std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);

/// A scatter map of values over two angles, coloured on a scale whose lightness rises with the
/// value (readable in greyscale print), with a legend: `x_deg` and `y_deg` of each point, `value`
/// of it in value_label's unit. Axes from x_lo to x_hi and y_lo to y_hi [deg], y growing
/// downwards (phi from the pole). Returns a standalone SVG document (for Figure()).
struct MapAxes {
  std::string title;
  std::string x_label;  ///< with its unit, e.g. "theta [deg]"
  std::string y_label;
  std::string value_label;  ///< with its unit, e.g. "residual [um]"
  double x_lo = 0.0, x_hi = 360.0, y_lo = 0.0, y_hi = 180.0;
  /// > 0: the values are on a grid of this step [deg], each drawn as the cell it centres; 0: a dot each
  double cell_deg = 0.0;
  /// The colour scale's ends, in value_label's unit; both NaN (the default): the values' own
  /// minimum and maximum. Two maps to be compared share one.
  double value_lo = std::numeric_limits<double>::quiet_NaN(), value_hi = std::numeric_limits<double>::quiet_NaN();
  /// The plot area [px]: a map meant for half a page's width is smaller, so that its text keeps
  /// its size.
  double plot_width = 480, plot_height = 240;
};
std::string SvgMap(const MapAxes& axes, const std::vector<double>& x_deg, const std::vector<double>& y_deg,
                   const std::vector<double>& value);

/// A curve over an angle with its band, for the error curves: the band from `low` to `high` as a
/// light grey fill and the curve as a black line (readable in greyscale print), the points
/// `mark_x`, `mark_value` (a table's) as open circles, with a legend and both axes labelled.
/// Axes from x_lo to x_hi [deg]; the values' axis fits the band. Returns a standalone SVG
/// document (for Figure()).
struct CurveAxes {
  std::string title;
  std::string x_label;  ///< with its unit, e.g. "theta [deg]"
  std::string y_label;  ///< with its unit, e.g. "theta_encoder [arcsec]"
  double x_lo = 0.0, x_hi = 360.0;
};
std::string SvgCurve(const CurveAxes& axes, const std::vector<double>& x, const std::vector<double>& value,
                     const std::vector<double>& low, const std::vector<double>& high,
                     const std::vector<double>& mark_x = {}, const std::vector<double>& mark_value = {});

}  // namespace sph::html

#endif  // SPH_IO_HTML_REPORT_HPP_
