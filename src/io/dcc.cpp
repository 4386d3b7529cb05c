#include "sph/io/dcc.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <set>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/gum.hpp"
#include "sph/stats/rounding.hpp"

namespace sph::dcc {

using internal::Format;
using internal::Quoted;

const std::vector<KeyInfo> kDccKeys = {
    {"certificate_id", "the certificate's unique identifier", true, true, false},
    {"country_code", "the laboratory's country, ISO 3166-1 (two capitals: DE)", true, true, false},
    {"performance_date", "the day the readings were taken, YYYY-MM-DD (else the points header's `started`)", false,
     false, false},
    {"performance_end_date", "the last day, YYYY-MM-DD (else from `started` and the readings' times)", false, false,
     false},
    {"performance_location", "laboratory (the default), customer, laboratoryBranch, customerBranch or other", false,
     false, false},
    {"laboratory_name", "the calibration laboratory's name", true, true, false},
    {"laboratory_email", "its e-mail address", true, true, false},
    {"laboratory_city", "its city", true, true, false},
    {"laboratory_street", "its street", false, false, false},
    {"laboratory_street_no", "its street number", false, false, false},
    {"laboratory_post_code", "its post code", false, false, false},
    {"laboratory_code", "its accreditation code", false, false, false},
    {"customer_name", "the customer's name", true, true, false},
    {"customer_email", "the customer's e-mail address", true, true, false},
    {"customer_city", "the customer's city", true, true, false},
    {"customer_street", "the customer's street", false, false, false},
    {"customer_street_no", "the customer's street number", false, false, false},
    {"customer_post_code", "the customer's post code", false, false, false},
    {"customer_country_code", "the customer's country, ISO 3166-1", false, false, false},
    {"responsible_person", "a person responsible, `Name` or `Name; role`; the first signs", true, true, true},
    {"scms_name", "the SCMS's name (default: spherical coordinate measuring system)", false, false, false},
    {"scms_manufacturer", "the SCMS's manufacturer", true, false, false},
    {"scms_model", "the SCMS's model", false, false, false},
    {"scms_serial", "the SCMS's serial number", true, false, false},
    {"sphere_name", "the sphere's name (default: reference sphere, or measured sphere)", false, false, false},
    {"sphere_manufacturer", "the sphere's manufacturer", false, true, false},
    {"sphere_serial", "the sphere's serial number", false, true, false},
    {"sphere_certificate", "the reference sphere's calibration certificate (the one R0 comes from)", true, false,
     false},
};

namespace {

const KeyInfo* Find(const std::string& key) {
  for (const KeyInfo& k : kDccKeys) {
    if (key == k.key) return &k;
  }
  return nullptr;
}

bool IsDate(const std::string& v) {
  if (v.size() != 10 || v[4] != '-' || v[7] != '-') return false;
  for (const std::size_t i : {0, 1, 2, 3, 5, 6, 8, 9}) {
    if (v[i] < '0' || v[i] > '9') return false;
  }
  const int month = std::stoi(v.substr(5, 2)), day = std::stoi(v.substr(8, 2));
  return month >= 1 && month <= 12 && day >= 1 && day <= 31;
}

bool IsCountry(const std::string& v) {
  return v.size() == 2 && std::all_of(v.begin(), v.end(), [](char c) { return c >= 'A' && c <= 'Z'; });
}

// Why `value` is not one `key` takes, or "".
std::string Refusal(const std::string& key, const std::string& value) {
  if (value.empty()) return key + ": no value";
  if ((key == "performance_date" || key == "performance_end_date") && !IsDate(value)) {
    return key + ": " + Quoted(value) + " is not a date YYYY-MM-DD";
  }
  if ((key == "country_code" || key == "customer_country_code") && !IsCountry(value)) {
    return key + ": " + Quoted(value) + " is not an ISO 3166-1 country code (two capitals: DE)";
  }
  static const std::set<std::string> kLocations = {"laboratory", "customer", "laboratoryBranch", "customerBranch",
                                                   "other"};
  if (key == "performance_location" && kLocations.count(value) == 0) {
    return key + ": " + Quoted(value) + " is not laboratory, customer, laboratoryBranch, customerBranch or other";
  }
  return "";
}

std::string Trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// The administrative values: the settings', then the header's over them (a repeated key: the
// header's entries replace the settings').
class Values {
 public:
  Values(const Settings& settings, const std::vector<std::pair<std::string, std::string>>& header) {
    for (const Field& f : settings.fields) values_[f.key].push_back(f.value);
    std::map<std::string, std::vector<std::string>> from_header;
    for (const auto& [key, value] : header) {
      if (Find(key) != nullptr) from_header[key].push_back(Trim(value));
    }
    for (auto& [key, list] : from_header) {
      for (const std::string& v : list) {
        const std::string why = Refusal(key, v);
        if (!why.empty()) throw Error("the points header's " + why);
      }
      values_[key] = list;
    }
  }
  std::string Get(const std::string& key, const std::string& fallback = "") const {
    const auto it = values_.find(key);
    return it == values_.end() || it->second.empty() ? fallback : it->second.front();
  }
  std::vector<std::string> All(const std::string& key) const {
    const auto it = values_.find(key);
    return it == values_.end() ? std::vector<std::string>{} : it->second;
  }
  bool Has(const std::string& key) const { return !Get(key).empty(); }

 private:
  std::map<std::string, std::vector<std::string>> values_;
};

// The XML text: elements opened and closed in order, indented, text and attributes escaped.
class Xml {
 public:
  void Open(const std::string& tag, const std::string& attributes = "") {
    text_ += Indent() + "<" + tag + attributes + ">\n";
    open_.push_back(tag);
  }
  void Close() {
    const std::string tag = open_.back();
    open_.pop_back();
    text_ += Indent() + "</" + tag + ">\n";
  }
  void Leaf(const std::string& tag, const std::string& text, const std::string& attributes = "") {
    text_ += Indent() + "<" + tag + attributes + ">" + Escape(text) + "</" + tag + ">\n";
  }
  // A dcc:textType or dcc:richContentType: the text as one English content.
  void Text(const std::string& tag, const std::string& text) {
    Open(tag);
    Leaf("dcc:content", text, " lang=\"en\"");
    Close();
  }
  static std::string Escape(const std::string& s) {
    std::string out;
    for (const char c : s) {
      switch (c) {
        case '&':
          out += "&amp;";
          break;
        case '<':
          out += "&lt;";
          break;
        case '>':
          out += "&gt;";
          break;
        case '"':
          out += "&quot;";
          break;
        default:
          // XML 1.0 holds no control character but tab (not even as a reference): written as the
          // output layer writes them, \u00hh.
          if ((static_cast<unsigned char>(c) < 0x20 && c != '\t') || c == '\x7f') {
            out += internal::Format("\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          } else {
            out += c;
          }
      }
    }
    return out;
  }
  static std::string Attribute(const std::string& name, const std::string& value) {
    return " " + name + "=\"" + Escape(value) + "\"";
  }
  const std::string& str() const { return text_; }

 private:
  std::string Indent() const { return std::string(2 * open_.size(), ' '); }
  std::string text_ = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  std::vector<std::string> open_;
};

// An XML id (an NCName) from a report's key: characters other than letters, digits, '.', '-' and
// '_' become '_'; one that does not start with a letter gets "q_" before it.
std::string IdOf(const std::string& key) {
  std::string id;
  for (const char c : key) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '-' || c == '_';
    id += ok ? c : '_';
  }
  if (id.empty() || !((id[0] >= 'a' && id[0] <= 'z') || (id[0] >= 'A' && id[0] <= 'Z'))) id = "q_" + id;
  return id;
}

void WriteQuantity(Xml& x, const Quantity& q) {
  x.Open("dcc:quantity", q.id.empty() ? "" : Xml::Attribute("id", IdOf(q.id)));
  x.Text("dcc:name", q.name);
  if (!q.description.empty()) x.Text("dcc:description", q.description);
  if (!std::isfinite(q.value)) {
    x.Text("dcc:noQuantity", q.text.empty() ? "not determined" : q.text);
    x.Close();
    return;
  }
  // GUM 7.2.6: U to two significant digits, the value to the same place, in the SI unit.
  const gum::RoundedResult r = gum::RoundResult(q.value, q.uncertainty);
  x.Open("si:real");
  x.Leaf("si:value", r.value_text);
  x.Leaf("si:unit", q.unit);
  if (std::isfinite(q.uncertainty)) {
    x.Open("si:expandedUnc");
    x.Leaf("si:uncertainty", r.uncertainty_text);
    x.Leaf("si:coverageFactor", Format("%.4g", q.coverage_factor));
    x.Leaf("si:coverageProbability", Format("%.4f", std::clamp(q.coverage_probability, 0.0, 1.0)));
    x.Close();
  }
  x.Close();
  x.Close();
}

void WriteLocation(Xml& x, const Values& v, const std::string& who, const std::string& country) {
  x.Open("dcc:location");
  x.Leaf("dcc:city", v.Get(who + "_city"));
  if (!country.empty()) x.Leaf("dcc:countryCode", country);
  if (v.Has(who + "_post_code")) x.Leaf("dcc:postCode", v.Get(who + "_post_code"));
  if (v.Has(who + "_street")) x.Leaf("dcc:street", v.Get(who + "_street"));
  if (v.Has(who + "_street_no")) x.Leaf("dcc:streetNo", v.Get(who + "_street_no"));
  x.Close();
}

void WriteContact(Xml& x, const std::string& tag, const Values& v, const std::string& who, const std::string& country) {
  x.Open(tag);
  x.Text("dcc:name", v.Get(who + "_name"));
  x.Leaf("dcc:eMail", v.Get(who + "_email"));
  WriteLocation(x, v, who, country);
  x.Close();
}

// An identification of an item or of equipment: who issued it, its value, what it is.
void WriteIdentification(Xml& x, const std::string& issuer, const std::string& value, const std::string& name) {
  x.Open("dcc:identification");
  x.Leaf("dcc:issuer", issuer);
  x.Leaf("dcc:value", value);
  x.Text("dcc:name", name);
  x.Close();
}

// One of the SCMS's devices, from a header line of sph_acquired: as an item or as equipment.
void WriteDevice(Xml& x, const std::string& tag, const HeaderDevice& d) {
  x.Open(tag);
  x.Text("dcc:name", (d.name.empty() ? d.role : d.name) + " (" + d.role + ")");
  x.Text("dcc:description", "a device of the SCMS, identified over CANopen SDO when the points were acquired");
  x.Open("dcc:manufacturer");
  x.Text("dcc:name", d.vendor_id.empty() ? "not identified" : "CANopen vendor-ID " + d.vendor_id);
  x.Close();
  if (!d.product_code.empty()) x.Leaf("dcc:model", "product code " + d.product_code);
  x.Open("dcc:identifications");
  if (!d.serial.empty()) WriteIdentification(x, "manufacturer", d.serial, "serial number (1018h sub 4)");
  if (!d.revision.empty()) WriteIdentification(x, "manufacturer", d.revision, "revision number (1018h sub 3)");
  WriteIdentification(x, "other", d.node.empty() ? d.role : "node " + d.node, "CANopen node-ID");
  x.Close();
  x.Close();
}

// The SCMS: an item of a calibration, the measuring equipment of a measurement.
void WriteScms(Xml& x, const std::string& tag, const Values& v, const Content& c) {
  x.Open(tag);
  x.Text("dcc:name", v.Get("scms_name", "spherical coordinate measuring system"));
  if (c.kind == Kind::kMeasurement) {
    std::string cal = "compensated with the calibration file " + c.calibration_file;
    for (const auto& [key, value] : c.calibration_source) {
      if (key == "certificate_id") cal += ", of the calibration certificate " + value;
    }
    x.Text("dcc:description", cal);
  }
  x.Open("dcc:manufacturer");
  x.Text("dcc:name", v.Get("scms_manufacturer", "not stated"));
  x.Close();
  if (v.Has("scms_model")) x.Leaf("dcc:model", v.Get("scms_model"));
  x.Open("dcc:identifications");
  WriteIdentification(x, "manufacturer", v.Get("scms_serial", "not stated"), "serial number");
  x.Close();
  x.Close();
}

// The sphere: the reference of a calibration (with its certificate), the item of a measurement.
void WriteSphere(Xml& x, const std::string& tag, const Values& v, Kind kind) {
  x.Open(tag);
  x.Text("dcc:name", v.Get("sphere_name", kind == Kind::kCalibration ? "reference sphere" : "measured sphere"));
  if (kind == Kind::kCalibration) {
    x.Text("dcc:description", "the reference sphere whose radius R0 (its certificate's) the calibration fits to");
  }
  if (v.Has("sphere_manufacturer") || kind == Kind::kMeasurement) {
    x.Open("dcc:manufacturer");
    x.Text("dcc:name", v.Get("sphere_manufacturer"));
    x.Close();
  }
  x.Open("dcc:identifications");
  if (v.Has("sphere_serial")) WriteIdentification(x, "manufacturer", v.Get("sphere_serial"), "serial number");
  if (v.Has("sphere_certificate")) {
    WriteIdentification(x, "other", v.Get("sphere_certificate"), "calibration certificate of the sphere");
  }
  x.Close();
  x.Close();
}

// "2026-12-04" of sph_acquired's "2026-12-04T10:00:00Z", plus `seconds`; "" when not such a time.
std::string DateOf(const std::string& started, double seconds) {
  std::tm tm{};
  if (std::sscanf(started.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                  &tm.tm_min, &tm.tm_sec) != 6) {
    return "";
  }
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  std::time_t t = timegm(&tm);
  if (t == static_cast<std::time_t>(-1)) return "";
  t += static_cast<std::time_t>(std::isfinite(seconds) && seconds > 0.0 ? seconds : 0.0);
  std::tm out{};
  gmtime_r(&t, &out);
  char text[16];
  std::strftime(text, sizeof text, "%Y-%m-%d", &out);
  return IsDate(text) ? text : "";
}

std::string HeaderValue(const Content& c, const std::string& key) {
  for (const auto& [k, v] : c.header) {
    if (k == key) return Trim(v);
  }
  return "";
}

// Every required key neither given nor derived, in one message.
void CheckRequired(const Values& v, const Content& c, const std::string& begin) {
  std::string missing;
  for (const KeyInfo& k : kDccKeys) {
    const bool required = c.kind == Kind::kCalibration ? k.calibration : k.measurement;
    if (required && !v.Has(k.key)) missing += std::string("\n  ") + k.key + ": " + k.what;
  }
  if (begin.empty()) {
    missing +=
        "\n  performance_date: the day the readings were taken, YYYY-MM-DD (the points header has no "
        "`started`, which sph_acquired writes)";
  }
  if (!missing.empty()) {
    throw Error("the certificate lacks what neither the settings file (--dcc-settings) nor the points header (" +
                c.points_file + ") gives; each key may stand in either, as `key: value`:" + missing);
  }
}

// The software that made the certificate (dcc:software), as dccSoftware and usedSoftware name it.
void WriteSoftware(Xml& x, const Content& c) {
  x.Open("dcc:software");
  x.Text("dcc:name", c.software);
  x.Leaf("dcc:release", c.release);
  x.Leaf("dcc:type", "application");
  x.Close();
}

void WriteAdministrativeData(Xml& x, const Values& v, const Content& c, const std::string& begin,
                             const std::string& end) {
  x.Open("dcc:administrativeData");
  x.Open("dcc:dccSoftware");
  WriteSoftware(x, c);
  x.Close();
  x.Open("dcc:coreData");
  x.Leaf("dcc:countryCodeISO3166_1", v.Get("country_code"));
  x.Leaf("dcc:usedLangCodeISO639_1", "en");
  x.Leaf("dcc:mandatoryLangCodeISO639_1", "en");
  x.Leaf("dcc:uniqueIdentifier", v.Get("certificate_id"));
  x.Leaf("dcc:beginPerformanceDate", begin);
  x.Leaf("dcc:endPerformanceDate", end);
  x.Leaf("dcc:performanceLocation", v.Get("performance_location", "laboratory"));
  x.Close();
  x.Open("dcc:items");
  if (c.kind == Kind::kCalibration) {
    WriteScms(x, "dcc:item", v, c);
    for (const HeaderDevice& d : DevicesOf(c.header)) WriteDevice(x, "dcc:item", d);
  } else {
    WriteSphere(x, "dcc:item", v, c.kind);
  }
  x.Close();
  x.Open("dcc:calibrationLaboratory");
  if (v.Has("laboratory_code")) x.Leaf("dcc:calibrationLaboratoryCode", v.Get("laboratory_code"));
  WriteContact(x, "dcc:contact", v, "laboratory", v.Get("country_code"));
  x.Close();
  x.Open("dcc:respPersons");
  bool first = true;
  for (const std::string& person : v.All("responsible_person")) {
    const std::size_t semicolon = person.find(';');
    x.Open("dcc:respPerson");
    x.Open("dcc:person");
    x.Text("dcc:name", Trim(person.substr(0, semicolon)));
    x.Close();
    if (semicolon != std::string::npos) x.Leaf("dcc:role", Trim(person.substr(semicolon + 1)));
    x.Leaf("dcc:mainSigner", first ? "true" : "false");
    x.Close();
    first = false;
  }
  x.Close();
  WriteContact(x, "dcc:customer", v, "customer", v.Get("customer_country_code"));
  x.Open("dcc:statements");
  x.Open("dcc:statement");
  x.Leaf("dcc:norm", "JCGM 100:2008");
  x.Text("dcc:declaration",
         "Each result is stated with its expanded uncertainty U = k u to two significant digits and the value "
         "rounded to the same decimal place (JCGM 100:2008, 7.2.6), in SI units.");
  x.Close();
  x.Close();
  x.Close();
}

}  // namespace

Quantity InSi(const std::string& id, const std::string& name, double value, const std::string& report_unit, double U,
              double coverage_factor, double coverage_probability) {
  static const std::map<std::string, std::pair<double, const char*>> kToSi = {
      {"deg", {kPi / 180.0, "\\radian"}}, {"urad", {1e-6, "\\radian"}}, {"arcsec", {kPi / 648000.0, "\\radian"}},
      {"mm", {1e-3, "\\metre"}},          {"um", {1e-6, "\\metre"}},    {"nm", {1e-9, "\\metre"}}};
  const auto it = kToSi.find(report_unit);
  const double f = it == kToSi.end() ? 1.0 : it->second.first;
  Quantity q;
  q.id = id;
  q.name = name;
  q.value = value * f;
  q.unit = it == kToSi.end() ? "\\one" : it->second.second;
  q.uncertainty = U * f;
  q.coverage_factor = coverage_factor;
  q.coverage_probability = coverage_probability;
  return q;
}

double ProbabilityOfK(double k) { return std::erf(k / std::sqrt(2.0)); }
double KOfProbability(double p) { return gum::NormalQuantile(0.5 * (1.0 + p)); }

Settings ParseSettings(std::istream& in, const std::string& source) {
  Settings s;
  TextLines lines(in, source, "a settings file of the certificate");
  std::string line;
  std::set<std::string> seen;
  while (lines.Next(line)) {
    const std::string t = Trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::size_t colon = t.find(':');
    if (colon == std::string::npos) {
      throw Error(lines.Where() + "expected `key: value`, got " + Quoted(t));
    }
    const std::string key = Trim(t.substr(0, colon)), value = Trim(t.substr(colon + 1));
    const KeyInfo* info = Find(key);
    if (info == nullptr) {
      throw Error(lines.Where() + "unknown key " + Quoted(key) + " (the keys: docs/dcc.md)");
    }
    if (!seen.insert(key).second && !info->repeated) throw Error(lines.Where() + key + " is given twice");
    // The XML is UTF-8 and holds no control character: a value must be text of one line.
    if (const std::string reason = NotUtf8Reason(value); !reason.empty()) {
      throw Error(lines.Where() + key + ": " + Quoted(value) + " " + reason + ": save the file as UTF-8");
    }
    for (std::size_t i = 0; i < value.size(); ++i) {
      const auto c = static_cast<unsigned char>(value[i]);
      if ((c < 0x20 && c != '\t') || c == 0x7f) {
        throw Error(lines.Where() + key + ": " + Quoted(value) + " holds a control character (" +
                    internal::Format("0x%02X", c) + " at character " + std::to_string(i + 1) +
                    "): a value is text of one line");
      }
    }
    const std::string why = Refusal(key, value);
    if (!why.empty()) throw Error(lines.Where() + why);
    s.fields.push_back({key, value, lines.Where().substr(0, lines.Where().size() - 2)});
  }
  return s;
}

Settings ReadSettings(const std::string& path) {
  std::ifstream in = OpenInputFile(path);
  return ParseSettings(in, path);
}

std::string WriteCertificate(const Content& c, const Settings& settings) {
  const Values v(settings, c.header);
  const std::string started = HeaderValue(c, "started");
  const std::string begin = v.Has("performance_date") ? v.Get("performance_date") : DateOf(started, 0.0);
  CheckRequired(v, c, begin);
  std::string end = v.Get("performance_end_date");
  if (end.empty()) end = v.Has("performance_date") ? begin : DateOf(started, c.duration_s);
  if (end < begin) throw Error("performance_end_date " + end + " is before the performance date " + begin);

  Xml x;
  x.Open("dcc:digitalCalibrationCertificate",
         Xml::Attribute("xmlns:dcc", "https://ptb.de/dcc") + Xml::Attribute("xmlns:si", "https://ptb.de/si") +
             Xml::Attribute("xmlns:xsi", "http://www.w3.org/2001/XMLSchema-instance") +
             Xml::Attribute("xsi:schemaLocation", "https://ptb.de/dcc https://ptb.de/dcc/v3.1.2/dcc.xsd") +
             Xml::Attribute("schemaVersion", "3.1.2"));
  WriteAdministrativeData(x, v, c, begin, end);
  x.Open("dcc:measurementResults");
  x.Open("dcc:measurementResult");
  x.Text("dcc:name", c.title);
  if (!c.description.empty()) x.Text("dcc:description", c.description);
  if (!c.methods.empty()) {
    x.Open("dcc:usedMethods");
    for (const Method& m : c.methods) {
      x.Open("dcc:usedMethod");
      x.Text("dcc:name", m.name);
      if (!m.description.empty()) x.Text("dcc:description", m.description);
      for (const std::string& norm : m.norms) x.Leaf("dcc:norm", norm);
      for (const std::string& ref : m.references) x.Leaf("dcc:reference", ref);
      x.Close();
    }
    x.Close();
  }
  x.Open("dcc:usedSoftware");
  WriteSoftware(x, c);
  x.Close();
  x.Open("dcc:measuringEquipments");
  if (c.kind == Kind::kCalibration) {
    WriteSphere(x, "dcc:measuringEquipment", v, c.kind);
  } else {
    WriteScms(x, "dcc:measuringEquipment", v, c);
    for (const HeaderDevice& d : DevicesOf(c.header)) WriteDevice(x, "dcc:measuringEquipment", d);
  }
  x.Close();
  if (!c.conditions.empty()) {
    x.Open("dcc:influenceConditions");
    for (const Quantity& q : c.conditions) {
      x.Open("dcc:influenceCondition");
      x.Text("dcc:name", q.name);
      x.Open("dcc:data");
      WriteQuantity(x, q);
      x.Close();
      x.Close();
    }
    x.Close();
  }
  x.Open("dcc:results");
  for (const Result& r : c.results) {
    x.Open("dcc:result");
    x.Text("dcc:name", r.name);
    if (!r.description.empty()) x.Text("dcc:description", r.description);
    x.Open("dcc:data");
    for (const Quantity& q : r.quantities) WriteQuantity(x, q);
    x.Close();
    x.Close();
  }
  x.Close();
  x.Close();
  x.Close();
  x.Close();
  return x.str();
}

}  // namespace sph::dcc
