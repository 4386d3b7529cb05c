#include <cstddef>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/core/error.hpp"
#include "sph/io/html_report.hpp"
#include "sph/io/points_file.hpp"
#include "sph/measure/measure_workflow.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/rounding.hpp"

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

// The seven errors as GUM 7.2.6 states them, from the JSON's values: U to two significant digits
// and the value to the same place, in urad and um; the budget with the inputs stated and one line
// of those not stated.
TEST(CalibrationHtml, HoldsTheJsonReportsValuesRoundedAsTheGumStatesThem) {
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kUndeclared, {});
  const std::string page = run.HtmlReport();
  const json j = json::parse(run.JsonReport());
  ExpectSelfContained(page);
  int found = 0;
  for (const json& name : j.at("parameter_order")) {
    const std::string key = name.get<std::string>();
    if (key.find('@') != std::string::npos) continue;
    const json& p = j.at("parameters").at(key);
    const double to_fine = p.at("unit") == "deg" ? kUradPerRad * kRadPerDeg : kUmPerMm;
    const gum::RoundedResult stated =
        gum::RoundResult(p.at("value").get<double>() * to_fine, p.at("U").get<double>() * to_fine);
    EXPECT_LE(stated.uncertainty_text.find_first_not_of("0."), stated.uncertainty_text.size() - 2) << key;
    for (const std::string& printed :
         {stated.value_text, stated.uncertainty_text, gum::SignificantText(p.at("u").get<double>() * to_fine),
          html::Fixed(p.at("k").get<double>(), 2)}) {
      EXPECT_TRUE(HasCell(page, printed)) << key << " " << printed;
      ++found;
    }
    const std::string iso = p.at("iso_name").get<std::string>();
    EXPECT_TRUE(iso.empty() ? HasCell(page, "&mdash;, see the model page")
                            : HasCell(page, "<span class=\"words\">" + iso + "</span>"))
        << key;
  }
  EXPECT_EQ(found, 7 * 4);
  EXPECT_TRUE(HasCell(page, "350.2"));  // alpha, U 3.4 urad: by hand from the JSON's 0.0200632 deg
  ASSERT_FALSE(j.at("effects").empty());
  for (const json& e : j.at("effects")) {
    for (const json& p : e.at("parameters")) {
      const gum::RoundedResult r = gum::RoundResult(p.at("value").get<double>(), p.at("std").get<double>());
      EXPECT_TRUE(HasCell(page, r.value_text)) << p.at("name");
      EXPECT_TRUE(HasCell(page, r.uncertainty_text)) << p.at("name");
    }
  }
  EXPECT_TRUE(HasCell(page, html::Fixed(j.at("after").at("rms_um").get<double>(), 4)));
  EXPECT_TRUE(HasCell(page, html::Fixed(j.at("before").at("cv_rms_um").get<double>(), 4)));
  // The example states no Type B input: the budget has the fit's column alone, and says so.
  EXPECT_THAT(page, HasSubstr("<th>fit (scatter of the points)</th>"));
  EXPECT_THAT(page, Not(HasSubstr("<th>R0 (certificate)</th>")));
  EXPECT_THAT(page, HasSubstr("Not stated, taken as exact: R0 (certificate) (<span class=\"nw\">sphere_radius_u_um"));
  EXPECT_THAT(page, HasSubstr(j.at("program").get<std::string>()));
  // The residual maps before and after, side by side.
  EXPECT_THAT(page, HasSubstr("<img alt=\"Before: the seven errors\""));
  EXPECT_THAT(page, HasSubstr("<img alt=\"After: with the effects found\""));
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
    const gum::RoundedResult range =
        gum::RoundResult(c.at("pv_" + unit).get<double>(), c.at("pv_u95_" + unit).get<double>());
    EXPECT_THAT(page, HasSubstr(range.value_text + " ± " + range.uncertainty_text + " (U95)"));
    const json& values = c.at("value_" + unit);
    const json& u95 = c.at("u95_" + unit);
    ASSERT_EQ(values.size(), c.at("angle_deg").size());
    for (std::size_t k = 0; k < values.size(); ++k) {
      const gum::RoundedResult r = gum::RoundResult(values[k].get<double>(), u95[k].get<double>());
      EXPECT_TRUE(HasCell(page, r.value_text)) << k;
      EXPECT_TRUE(HasCell(page, r.uncertainty_text)) << k;
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
  for (const char* cell : {"1", "3"}) EXPECT_TRUE(HasCell(page, cell)) << cell;
  // A name breaks between its words only, never inside one.
  for (const char* name : {"sph_cansim theta encoder", "probe &lt;7&gt;"}) {
    EXPECT_TRUE(HasCell(page, std::string("<span class=\"words\">") + name + "</span>")) << name;
  }
  EXPECT_THAT(page, HasSubstr(".words { overflow-wrap: normal; }"));
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
  EXPECT_TRUE(HasCell(page, html::Fixed(j.at("diameter_mm").get<double>(), 6)));
  // The radius and the sphericities as GUM 7.2.6 states them, with their U (in um).
  const json& b = j.at("budget");
  const gum::RoundedResult radius =
      gum::RoundResult(b.at("radius").at("value").get<double>(), b.at("radius").at("U").get<double>() / kUmPerMm);
  EXPECT_TRUE(HasCell(page, radius.value_text + " mm"));
  EXPECT_TRUE(HasCell(page, gum::SignificantText(b.at("radius").at("U").get<double>()) + " um"));
  for (const char* key : {"sphericity_ls", "sphericity_mz"}) {
    const gum::RoundedResult r = gum::RoundResult(b.at(key).at("value").get<double>(), b.at(key).at("U").get<double>());
    EXPECT_TRUE(HasCell(page, r.value_text + " um")) << key;
  }
  EXPECT_THAT(page, HasSubstr("<h3>The points file's header</h3>"));
  // The form map is there, its SVG as a data: URL.
  EXPECT_THAT(page, HasSubstr("<img alt=\"Form error about the least-squares sphere\" src=\"data:image/svg+xml;base64,"));
}

}  // namespace
}  // namespace sph
