#include <cstddef>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/core/error.hpp"
#include "sph/io/html_report.hpp"
#include "sph/measure/measure_workflow.hpp"
#include "sph/io/points_file.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using nlohmann::json;

const std::string kUndeclared = SPH_SOURCE_DIR "/data/example/undeclared/points.txt";

// Nothing in the page is fetched from elsewhere: no URL, no style sheet or script of another file,
// no image but the page's own data: URLs.
void ExpectSelfContained(const std::string& page) {
  EXPECT_THAT(page, Not(HasSubstr("http")));
  EXPECT_THAT(page, Not(HasSubstr("<link")));
  EXPECT_THAT(page, Not(HasSubstr("<script")));
  EXPECT_THAT(page, Not(HasSubstr("url(")));
  EXPECT_THAT(page, Not(HasSubstr("@import")));
  EXPECT_THAT(page, Not(HasSubstr("href")));
  for (std::size_t at = page.find("src="); at != std::string::npos; at = page.find("src=", at + 1)) {
    const std::string data = "src=\"data:image/svg+xml;base64,";
    EXPECT_EQ(page.compare(at, data.size(), data), 0) << page.substr(at, 60);
  }
}

// The cell "<td ...>text</td>" is in the page.
bool HasCell(const std::string& page, const std::string& text) {
  return page.find(">" + text + "</td>") != std::string::npos;
}

TEST(HtmlReport, EscapesEveryMarkupCharacter) {
  EXPECT_EQ(html::Escape("<a href=\"x\">Tom & Jerry's</a>"),
            "&lt;a href=&quot;x&quot;&gt;Tom &amp; Jerry&#39;s&lt;/a&gt;");
  EXPECT_EQ(html::Number(0.0199524), "0.0199524");
  EXPECT_EQ(html::Number(-0.0), "0");
  EXPECT_EQ(html::Fixed(20.000000001, 6), "20.000000");
}

TEST(HtmlReport, MapHasItsAxesAndLegendWithUnits) {
  html::MapAxes axes;
  axes.title = "t";
  axes.x_label = "theta [deg]";
  axes.y_label = "phi [deg]";
  axes.value_label = "residual [um]";
  const std::string svg = html::SvgMap(axes, {0.0, 90.0}, {45.0, 135.0}, {-0.1, 0.2});
  EXPECT_THAT(svg, HasSubstr(">theta [deg]</text>"));
  EXPECT_THAT(svg, HasSubstr(">phi [deg]</text>"));
  EXPECT_THAT(svg, HasSubstr(">residual [um]</text>"));
  EXPECT_THAT(svg, HasSubstr(">-0.1</text>"));  // the legend's ends are the values' range
  EXPECT_THAT(svg, HasSubstr(">0.2</text>"));
  // The lowest value darkest, the highest lightest (greyscale keeps the order).
  EXPECT_THAT(svg, HasSubstr("fill=\"#440154\""));
  EXPECT_THAT(svg, HasSubstr("fill=\"#fde725\""));
}

TEST(CalibrationHtml, HoldsTheJsonReportsValuesAndNothingFromElsewhere) {
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kUndeclared, {});
  const std::string page = run.HtmlReport();
  const json j = json::parse(run.JsonReport());
  ExpectSelfContained(page);
  int found = 0;
  for (const json& name : j.at("parameter_order")) {
    const std::string key = name.get<std::string>();
    if (key.find('@') != std::string::npos) continue;
    const json& p = j.at("parameters").at(key);
    for (const char* field : {"value", "u", "k", "U"}) {
      const std::string printed = html::Number(p.at(field).get<double>());
      EXPECT_TRUE(HasCell(page, printed)) << key << "." << field << " " << printed;
      ++found;
    }
    EXPECT_TRUE(HasCell(page, p.at("iso_name").get<std::string>())) << key;
  }
  EXPECT_EQ(found, 7 * 4);
  ASSERT_FALSE(j.at("effects").empty());
  for (const json& e : j.at("effects")) {
    for (const json& p : e.at("parameters")) {
      EXPECT_TRUE(HasCell(page, html::Number(p.at("value").get<double>()))) << p.at("name");
    }
  }
  EXPECT_TRUE(HasCell(page, html::Number(j.at("after").at("rms_um").get<double>())));
  EXPECT_TRUE(HasCell(page, html::Number(j.at("before").at("cv_rms_um").get<double>())));
  EXPECT_THAT(page, HasSubstr("R0 taken as exact"));  // an input assumed
  EXPECT_THAT(page, HasSubstr(j.at("program").get<std::string>()));
}

TEST(HtmlReport, CurveHasItsAxesWithUnitsAndItsBandAsALightFillBesideABlackLine) {
  html::CurveAxes axes;
  axes.title = "theta_encoder (ECC)";
  axes.x_label = "theta [deg]";
  axes.y_label = "theta_encoder [arcsec]";
  const std::string svg =
      html::SvgCurve(axes, {0.0, 180.0, 360.0}, {1.0, -2.0, 1.0}, {0.5, -2.5, 0.5}, {1.5, -1.5, 1.5}, {90.0}, {-1.0});
  EXPECT_THAT(svg, HasSubstr(">theta [deg]</text>"));
  EXPECT_THAT(svg, HasSubstr(">theta_encoder [arcsec]</text>"));
  EXPECT_THAT(svg, HasSubstr("<polygon points=\"70.0,"));  // the band, from x_lo at the left edge
  EXPECT_THAT(svg, HasSubstr("fill=\"#cccccc\" stroke=\"none\""));
  EXPECT_THAT(svg, HasSubstr("<polyline"));
  EXPECT_THAT(svg, HasSubstr("stroke=\"#000000\""));
  EXPECT_THAT(svg, HasSubstr(">95 % band</text>"));
  EXPECT_THAT(svg, HasSubstr("<circle"));  // the table's point
  EXPECT_THROW(html::SvgCurve(axes, {0.0}, {1.0, 2.0}, {0.0}, {0.0}), Error);
}

TEST(CalibrationHtml, ShowsTheErrorCurvesWithTheJsonsValues) {
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kUndeclared, {});
  const std::string page = run.HtmlReport();
  const json j = json::parse(run.JsonReport());
  ASSERT_FALSE(j.at("error_curves").empty());  // the example's Theta encoder
  for (const json& c : j.at("error_curves")) {
    const std::string unit = c.at("unit").get<std::string>();
    EXPECT_THAT(page, HasSubstr(html::Number(c.at("pv_" + unit).get<double>()) + " ± " +
                                html::Number(c.at("pv_u95_" + unit).get<double>())));
    const json& values = c.at("value_" + unit);
    const json& u95 = c.at("u95_" + unit);
    ASSERT_EQ(values.size(), c.at("angle_deg").size());
    for (std::size_t k = 0; k < values.size(); ++k) {
      EXPECT_TRUE(HasCell(page, html::Fixed(values[k].get<double>(), 3))) << k;
      EXPECT_TRUE(HasCell(page, html::Fixed(u95[k].get<double>(), 3))) << k;
    }
    EXPECT_THAT(page, HasSubstr("<img alt=\"" + c.at("id").get<std::string>() + " (" +
                                c.at("iso_name").get<std::string>() + ")\" src=\"data:image/svg+xml;base64,"));
  }
  ExpectSelfContained(page);
}

// The devices sph_acquired identified over SDO, as it writes them into the points file's header
// (CanopenMaster::HeaderFields()): a fixture, the replay of a simulated log having no SDO.
TEST(CalibrationHtml, ListsTheDevicesThatThePointsHeaderNames) {
  PointsData points = ReadPointsFile(kUndeclared);
  points.header.metadata.emplace_back(
      "device_theta_encoder",
      "node 1; name \"sph_cansim theta encoder\"; vendor_id 0x00535048; product_code 0x00004060; revision "
      "0x00010000; serial 0x00010001; measuring_units_per_revolution 8192; tpdo 1 cob_id 0x181");
  points.header.metadata.emplace_back("device_probe", "node 3; name \"probe <7>\"; tpdo 1 cob_id 0x183");
  CalibrationWorkflowOptions o;
  o.trace = false;
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(points, "acquired.txt", o);
  const json j = json::parse(run.JsonReport());
  ASSERT_EQ(j.at("devices").size(), 2U);
  const json& theta = j.at("devices")[0];
  EXPECT_EQ(theta.at("role"), "theta_encoder");
  EXPECT_EQ(theta.at("node"), "1");
  EXPECT_EQ(theta.at("name"), "sph_cansim theta encoder");
  EXPECT_EQ(theta.at("vendor_id"), "0x00535048");
  EXPECT_EQ(theta.at("product_code"), "0x00004060");
  EXPECT_EQ(theta.at("revision"), "0x00010000");
  EXPECT_EQ(theta.at("serial"), "0x00010001");
  EXPECT_FALSE(j.at("devices")[1].contains("serial"));  // not on its line
  const std::string page = run.HtmlReport();
  EXPECT_THAT(page, HasSubstr("<h3>Devices identified over SDO</h3>"));
  for (const char* cell : {"1", "sph_cansim theta encoder", "3", "probe &lt;7&gt;"}) {
    EXPECT_TRUE(HasCell(page, cell)) << cell;
  }
  // Identifiers and codes kept on one line.
  for (const char* code : {"theta_encoder", "0x00535048", "0x00004060", "0x00010000", "0x00010001", "probe"}) {
    EXPECT_TRUE(HasCell(page, std::string("<span class=\"nw\">") + code + "</span>")) << code;
  }
  ExpectSelfContained(page);
}

TEST(CalibrationHtml, EscapesTheTextOfTheInputFile) {
  PointsData points = ReadPointsFile(kUndeclared);
  points.header.metadata.emplace_back("operator<b>", "<script>alert('x')</script> & co");
  CalibrationWorkflowOptions o;
  o.trace = false;
  const std::string page = RunCalibrationWorkflow(points, "bench <1>.txt", o).HtmlReport();
  EXPECT_THAT(page, Not(HasSubstr("<script")));
  EXPECT_THAT(page, Not(HasSubstr("<b>")));
  EXPECT_THAT(page, HasSubstr("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; co"));
  EXPECT_THAT(page, HasSubstr("operator&lt;b&gt;"));
  EXPECT_THAT(page, HasSubstr("<title>Calibration report: bench &lt;1&gt;.txt</title>"));
}

TEST(MeasurementHtml, HoldsTheJsonReportsValuesAndNothingFromElsewhere) {
  MeasurementWorkflowOptions o;
  o.xyz = true;
  o.noise_floor_draws = 5;
  o.mc_max_trials = 0;
  o.uncertainty_samples = 0;
  const MeasurementWorkflowResult run =
      RunMeasurementWorkflow(SPH_SOURCE_DIR "/tests/data/nist-ats-l2-sphere/sph1.ds", o);
  const std::string page = run.HtmlReport();
  const json j = json::parse(run.JsonReport());
  ExpectSelfContained(page);
  EXPECT_TRUE(HasCell(page, html::Fixed(j.at("radius_mm").get<double>(), 6)));
  EXPECT_TRUE(HasCell(page, html::Fixed(j.at("diameter_mm").get<double>(), 6)));
  EXPECT_TRUE(HasCell(page, html::Number(j.at("sphericity_ls_um").get<double>())));
  EXPECT_TRUE(HasCell(page, html::Number(j.at("sphericity_mz_um").get<double>())));
  // The form map is there, its SVG as a data: URL.
  EXPECT_THAT(page, HasSubstr("<img alt=\"Form error about the least-squares sphere\" src=\"data:image/svg+xml;base64,"));
}

}  // namespace
}  // namespace sph
