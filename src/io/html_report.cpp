#include "sph/io/html_report.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <chrono>
#include <cstddef>
#include <ctime>

#include <nlohmann/json.hpp>

#include "sph/core/error.hpp"
#include "sph/internal/html_json.hpp"
#include "sph/internal/format.hpp"

namespace sph::html {

using internal::Format;

std::string Escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Number(double value) {
  if (!std::isfinite(value)) return "-";
  if (value == 0.0) return "0";  // not "-0"
  return Format("%.6g", value);
}

std::string Fixed(double value, int decimals) {
  if (!std::isfinite(value)) return "-";
  return Format("%.*f", decimals, value);
}

std::string JsonText(const nlohmann::json& v) {
  if (v.is_null()) return "-";
  if (v.is_number()) return Number(v.get<double>());
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_string()) return Escape(v.get<std::string>());
  return Escape(v.dump());
}

std::string JsonField(const nlohmann::json& j, const char* key) {
  return j.is_object() && j.contains(key) ? JsonText(j.at(key)) : "-";
}

std::string JsonList(const nlohmann::json& items) {
  if (!items.is_array() || items.empty()) return "<p>None.</p>\n";
  std::string out = "<ul>\n";
  for (const nlohmann::json& i : items) out += "<li>" + JsonText(i) + "</li>\n";
  return out + "</ul>\n";
}

std::string HeaderTables(const nlohmann::json& j) {
  using nlohmann::json;
  std::string body = "<h3>The points file's header</h3>\n";
  std::vector<std::vector<std::string>> meta;
  if (j.contains("metadata")) {
    for (const auto& [key, value] : j.at("metadata").items()) meta.push_back({Escape(key), JsonText(value)});
  }
  body += meta.empty() ? "<p>No further header fields.</p>\n" : Table({"field", "value"}, meta);
  // The devices sph_acquired identified over SDO (the header's device_* fields, as parsed).
  std::vector<std::vector<std::string>> devices;
  for (const json& d : j.value("devices", json::array())) {
    std::string other;
    for (const json& o : d.value("other", json::array())) other += (other.empty() ? "" : "; ") + JsonText(o);
    const auto code = [&](const char* key) { return "<span class=\"nw\">" + JsonField(d, key) + "</span>"; };
    devices.push_back({JsonField(d, "node"), code("role"), "<span class=\"words\">" + JsonField(d, "name") + "</span>",
                       code("vendor_id"), code("product_code"), code("revision"), code("serial"), other});
  }
  body += "<h3>Devices identified over SDO</h3>\n";
  body += devices.empty()
              ? "<p>None: the points file names no device (it was not acquired by sph_acquired, or its "
                "devices did not answer).</p>\n"
              : Table({"node", "role", "name", "vendor", "product", "revision", "serial", "further"}, devices);
  return body;
}

std::string UtcNow() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", &tm);
  return text;
}

namespace {

constexpr const char* kStyle = R"(
body { font-family: "DejaVu Sans", Arial, sans-serif; font-size: 10.5pt; margin: 1.5em auto; max-width: 60em;
       padding: 0 1em; color: #000; background: #fff; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #888; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.5em 0; max-width: 100%; }
th, td { border: 1px solid #999; padding: 0.15em 0.45em; text-align: left; vertical-align: top;
         overflow-wrap: anywhere; }
th, td:first-child { overflow-wrap: normal; }  /* names and headers break between words only */
td:first-child { max-width: 30em; overflow-wrap: break-word; }  /* at most 30em: a longer word breaks */
th { background: #e8e8e8; }
td.n { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.nw { white-space: nowrap; }  /* an identifier or code that must not break */
.note { color: #333; font-size: 0.95em; }
.warn { border-left: 4px solid #000; padding-left: 0.5em; }
.figure img { max-width: 100%; height: auto; }
.row { display: flex; flex-wrap: wrap; gap: 1em; }
.row .figure { flex: 1 1 20em; }
.words { overflow-wrap: normal; }  /* a name that breaks between its words only */
@page { size: A4; margin: 15mm; }
@media print {
  body { margin: 0; max-width: none; padding: 0; font-size: 9.5pt; }
  .section.page { break-before: page; }
  h2, h3, h4 { break-after: avoid; }
  table, .figure, img, tr { break-inside: avoid; }
  thead { display: table-header-group; }
  th { background: #e8e8e8 !important; -webkit-print-color-adjust: exact; print-color-adjust: exact; }
}
)";

// Viridis at 9 stops: its lightness rises monotonically, so greyscale keeps the order.
constexpr std::array<std::array<int, 3>, 9> kViridis{{{68, 1, 84},
                                                      {71, 44, 122},
                                                      {59, 81, 139},
                                                      {44, 113, 142},
                                                      {33, 144, 141},
                                                      {39, 173, 129},
                                                      {92, 200, 99},
                                                      {170, 220, 50},
                                                      {253, 231, 37}}};

std::string Colour(double f) {
  f = std::clamp(f, 0.0, 1.0) * (kViridis.size() - 1);
  const auto i = std::min(static_cast<std::size_t>(f), kViridis.size() - 2);
  const double w = f - static_cast<double>(i);
  std::array<int, 3> c{};
  for (int k = 0; k < 3; ++k) c[k] = static_cast<int>(std::lround(kViridis[i][k] * (1 - w) + kViridis[i + 1][k] * w));
  return Format("#%02x%02x%02x", c[0], c[1], c[2]);
}

// The start of a figure: the SVG element of `width` x `height` px, its title (as <title> and as a
// caption), and the plot area's frame at (left, top), `w` x `h` px, filled with `fill`.
std::string SvgStart(double width, double height, const std::string& title, double left, double top, double w,
                     double h, const char* fill) {
  std::string s = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" + Format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 %.0f %.0f\" width=\"%.0f\" height=\"%.0f\" "
      "font-family=\"DejaVu Sans, Arial, sans-serif\" font-size=\"11\">\n",
      width, height, width, height);
  s += "<title>" + Escape(title) + "</title>\n";
  s += Format("<text x=\"%.0f\" y=\"18\" font-size=\"13\">", left) + Escape(title) + "</text>\n";
  s += Format("<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"%s\" stroke=\"#000\"/>\n", left, top,
              w, h, fill);
  return s;
}


}  // namespace

std::string Figure(const std::string& svg, const std::string& alt, const std::string& caption) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string b64;
  b64.reserve((svg.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < svg.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, svg.size() - i);
    unsigned v = 0;
    for (std::size_t k = 0; k < 3; ++k) v = (v << 8) | (k < n ? static_cast<unsigned char>(svg[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) b64 += k <= n ? kDigits[(v >> (18 - 6 * k)) & 63u] : '=';
  }
  return "<div class=\"figure\"><img alt=\"" + Escape(alt) + "\" src=\"data:image/svg+xml;base64," + b64 +
         "\"><p class=\"note\">" + Escape(caption) + "</p></div>\n";
}

std::string Section(const std::string& title, const std::string& body, NewPage new_page) {
  return std::string(new_page == NewPage::kYes ? "<div class=\"section page\">" : "<div class=\"section\">") +
         "\n<h2>" + Escape(title) + "</h2>\n" + body + "</div>\n";
}

std::string FigureRow(const std::vector<std::string>& figures) {
  std::string out = "<div class=\"row\">\n";
  for (const std::string& f : figures) out += f;
  return out + "</div>\n";
}

std::string Page(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" + Escape(title) +
         "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n" + body + "</body>\n</html>\n";
}

std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::string out = "<table>\n<thead><tr>";
  for (const std::string& h : header) out += "<th>" + h + "</th>";
  out += "</tr></thead>\n<tbody>\n";
  for (const auto& row : rows) {
    out += "<tr>";
    for (const std::string& cell : row) {
      // A number, alone or with its unit ("20.000000 mm"), is right-aligned and kept on one line.
      const std::size_t space = cell.find(' ');
      const std::string lead = cell.substr(0, space);
      const bool number = !lead.empty() && lead.find_first_not_of("0123456789.eE+-") == std::string::npos &&
                          (space == std::string::npos || cell.size() - space <= 8);
      out += (number ? "<td class=\"n\">" : "<td>") + cell + "</td>";
    }
    out += "</tr>\n";
  }
  return out + "</tbody>\n</table>\n";
}

std::string SvgMap(const MapAxes& a, const std::vector<double>& x_deg, const std::vector<double>& y_deg,
                   const std::vector<double>& value) {
  if (x_deg.size() != y_deg.size() || x_deg.size() != value.size()) {
    throw Error("html map: the coordinates and the values differ in number");
  }
  constexpr double kLeft = 60, kTop = 30, kLegendW = 16;
  const double kW = a.plot_width, kH = a.plot_height, kLegendX = kLeft + kW + 40;
  const double width = kLegendX + kLegendW + 80, height = kTop + kH + 50;
  double lo = 0.0, hi = 0.0;
  if (std::isfinite(a.value_lo) && std::isfinite(a.value_hi)) {
    lo = a.value_lo;
    hi = a.value_hi;
  } else if (!value.empty()) {
    const auto [mn, mx] = std::minmax_element(value.begin(), value.end());
    lo = *mn;
    hi = *mx;
  }
  if (hi <= lo) hi = lo + 1.0;
  const auto px = [&](double x) { return kLeft + (x - a.x_lo) / (a.x_hi - a.x_lo) * kW; };
  const auto py = [&](double y) { return kTop + (y - a.y_lo) / (a.y_hi - a.y_lo) * kH; };
  std::string s = SvgStart(width, height, a.title, kLeft, kTop, kW, kH, "#f4f4f4");
  // Ticks every 60 deg on x and 30 deg on y.
  for (double x = a.x_lo; x <= a.x_hi + 1e-9; x += 60) {
    s += Format("<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#000\"/>"
                "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\">%g</text>\n",
                px(x), kTop + kH, px(x), kTop + kH + 4, px(x), kTop + kH + 16, x);
  }
  for (double y = a.y_lo; y <= a.y_hi + 1e-9; y += 30) {
    s += Format("<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#000\"/>"
                "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                kLeft - 4, py(y), kLeft, py(y), kLeft - 6, py(y) + 4, y);
  }
  s += Format("<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\">", kLeft + kW / 2, kTop + kH + 34) +
       Escape(a.x_label) + "</text>\n";
  s += Format("<text transform=\"translate(16 %.0f) rotate(-90)\" text-anchor=\"middle\">", kTop + kH / 2) +
       Escape(a.y_label) + "</text>\n";
  for (std::size_t i = 0; i < value.size(); ++i) {
    const std::string colour = Colour((value[i] - lo) / (hi - lo));
    if (a.cell_deg > 0) {
      const double x0 = std::max(a.x_lo, x_deg[i] - a.cell_deg / 2), x1 = std::min(a.x_hi, x_deg[i] + a.cell_deg / 2);
      const double y0 = std::max(a.y_lo, y_deg[i] - a.cell_deg / 2), y1 = std::min(a.y_hi, y_deg[i] + a.cell_deg / 2);
      s += Format("<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"%s\"/>\n", px(x0), py(y0),
                  px(x1) - px(x0) + 0.3, py(y1) - py(y0) + 0.3, colour.c_str());
    } else {
      s += Format("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"%.1f\" fill=\"%s\"/>\n", px(x_deg[i]), py(y_deg[i]),
                  std::max(2.5, 4.0 * kW / 480), colour.c_str());
    }
  }
  // The legend: the scale from lo (bottom) to hi (top), with its unit.
  constexpr int kSteps = 32;
  for (int k = 0; k < kSteps; ++k) {
    const double f = (k + 0.5) / kSteps;
    s += Format("<rect x=\"%.0f\" y=\"%.2f\" width=\"%.0f\" height=\"%.2f\" fill=\"%s\"/>\n", kLegendX,
                kTop + kH * (1 - static_cast<double>(k + 1) / kSteps), kLegendW, kH / kSteps + 0.3,
                Colour(f).c_str());
  }
  s += Format("<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"none\" stroke=\"#000\"/>\n",
              kLegendX, kTop, kLegendW, kH);
  for (int k = 0; k <= 4; ++k) {
    const double v = lo + (hi - lo) * k / 4.0, y = kTop + kH * (1 - k / 4.0);
    s += Format("<text x=\"%.0f\" y=\"%.1f\">%.3g</text>\n", kLegendX + kLegendW + 4, y + 4, v);
  }
  s += Format("<text transform=\"translate(%.0f %.0f) rotate(-90)\" text-anchor=\"middle\">",
              kLegendX - 8, kTop + kH / 2) +
       Escape(a.value_label) + "</text>\n";
  return s + "</svg>\n";
}

std::string SvgCurve(const CurveAxes& a, const std::vector<double>& x, const std::vector<double>& value,
                     const std::vector<double>& low, const std::vector<double>& high,
                     const std::vector<double>& mark_x, const std::vector<double>& mark_value) {
  if (x.size() != value.size() || x.size() != low.size() || x.size() != high.size() ||
      mark_x.size() != mark_value.size()) {
    throw Error("html curve: the coordinates and the values differ in number");
  }
  constexpr double kLeft = 70, kTop = 30, kW = 560, kH = 220;
  const double width = kLeft + kW + 20, height = kTop + kH + 80;
  double lo = 0.0, hi = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (std::isfinite(low[i])) lo = std::min(lo, low[i]);
    if (std::isfinite(high[i])) hi = std::max(hi, high[i]);
    if (std::isfinite(value[i])) lo = std::min(lo, value[i]), hi = std::max(hi, value[i]);
  }
  if (hi <= lo) hi = lo + 1.0;
  // A round step for the values' ticks, about five of them.
  const double raw = (hi - lo) / 5.0, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw / mag < 2 ? 2 * mag : raw / mag < 5 ? 5 * mag : 10 * mag;
  lo = std::floor(lo / step) * step;
  hi = std::ceil(hi / step) * step;
  const double x_span = a.x_hi > a.x_lo ? a.x_hi - a.x_lo : 1.0;
  const auto px = [&](double v) { return kLeft + (v - a.x_lo) / x_span * kW; };
  const auto py = [&](double v) { return kTop + (hi - v) / (hi - lo) * kH; };
  std::string s = SvgStart(width, height, a.title, kLeft, kTop, kW, kH, "#ffffff");
  // Ticks: every 30 deg (15 deg under 120 deg) on x, `step` on y, with light grid lines.
  const double x_step = x_span > 120 ? 30.0 : 15.0;
  for (double v = std::ceil(a.x_lo / x_step) * x_step; v <= a.x_hi + 1e-9; v += x_step) {
    s += Format("<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#dddddd\"/>"
                "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#000\"/>"
                "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\">%g</text>\n",
                px(v), kTop, px(v), kTop + kH, px(v), kTop + kH, px(v), kTop + kH + 4, px(v), kTop + kH + 16, v);
  }
  for (double v = lo; v <= hi + step * 1e-6; v += step) {
    s += Format("<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#dddddd\"/>"
                "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#000\"/>"
                "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                kLeft, py(v), kLeft + kW, py(v), kLeft - 4, py(v), kLeft, py(v), kLeft - 6, py(v) + 4,
                std::abs(v) < step * 1e-6 ? 0.0 : v);
  }
  s += Format("<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\">", kLeft + kW / 2, kTop + kH + 34) +
       Escape(a.x_label) + "</text>\n";
  s += Format("<text transform=\"translate(16 %.0f) rotate(-90)\" text-anchor=\"middle\">", kTop + kH / 2) +
       Escape(a.y_label) + "</text>\n";
  // The band: the polygon along `high` and back along `low`; then the curve; then the marks.
  std::string band, line;
  for (std::size_t i = 0; i < x.size(); ++i) band += Format("%.1f,%.1f ", px(x[i]), py(high[i]));
  for (std::size_t i = x.size(); i-- > 0;) band += Format("%.1f,%.1f ", px(x[i]), py(low[i]));
  for (std::size_t i = 0; i < x.size(); ++i) line += Format("%.1f,%.1f ", px(x[i]), py(value[i]));
  if (!x.empty()) {
    s += "<polygon points=\"" + band + "\" fill=\"#cccccc\" stroke=\"none\"/>\n";
    s += "<polyline points=\"" + line + "\" fill=\"none\" stroke=\"#000000\" stroke-width=\"1.6\"/>\n";
  }
  for (std::size_t i = 0; i < mark_x.size(); ++i) {
    s += Format("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"2.6\" fill=\"#ffffff\" stroke=\"#000000\"/>\n",
                px(mark_x[i]), py(mark_value[i]));
  }
  // The legend, below the plot.
  const double ly = kTop + kH + 56;
  s += Format("<rect x=\"%.0f\" y=\"%.0f\" width=\"24\" height=\"10\" fill=\"#cccccc\"/>"
              "<text x=\"%.0f\" y=\"%.0f\">95 %% band</text>\n",
              kLeft, ly - 9, kLeft + 30, ly);
  s += Format("<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"#000000\" stroke-width=\"1.6\"/>"
              "<text x=\"%.0f\" y=\"%.0f\">curve</text>\n",
              kLeft + 120, ly - 4, kLeft + 144, ly - 4, kLeft + 150, ly);
  if (!mark_x.empty()) {
    s += Format("<circle cx=\"%.0f\" cy=\"%.0f\" r=\"2.6\" fill=\"#ffffff\" stroke=\"#000000\"/>"
                "<text x=\"%.0f\" y=\"%.0f\">the table's angles</text>\n",
                kLeft + 222, ly - 4, kLeft + 230, ly);
  }
  return s + "</svg>\n";
}

}  // namespace sph::html
