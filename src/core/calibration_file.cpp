#include "sph/core/calibration_file.hpp"

#include <fstream>

#include <nlohmann/json.hpp>

#include "sph/core/atomic_file.hpp"
#include "sph/core/error.hpp"

namespace sph {
namespace {

using nlohmann::json;

const char* UnitOf(int p) { return kScmsParamInfo[static_cast<std::size_t>(p)].quantity == Quantity::kAngle ? "deg" : "mm"; }

const json& Field(const json& obj, const char* key, const std::string& where, const std::string& path) {
  if (!obj.is_object() || !obj.contains(key)) throw Error(path + ": missing field '" + where + key + "'");
  return obj.at(key);
}

double Number(const json& obj, const char* key, const std::string& where, const std::string& path) {
  const json& v = Field(obj, key, where, path);
  if (!v.is_number()) throw Error(path + ": field '" + where + key + "' must be a number");
  return v.get<double>();
}

}  // namespace

void WriteCalibrationFile(const std::string& path, const CalibrationFile& cal) {
  json j;
  j["format"] = "sph-calibration";
  j["format_version"] = kCalibrationFormatVersion;
  j["created_by"] = cal.created_by;
  j["probe_offset_mm"] = cal.probe_offset_mm;
  if (cal.sphere_radius_mm) j["sphere_radius_mm"] = *cal.sphere_radius_mm;
  json geometry = json::object();
  for (int p = 0; p < kNumScmsParams; ++p) {
    geometry[kScmsParamInfo[static_cast<std::size_t>(p)].name] = {
        {"value", ToReportUnits(p, cal.geometry[static_cast<std::size_t>(p)])}, {"unit", UnitOf(p)}};
  }
  j["geometry"] = geometry;
  if (cal.covariance) {
    json names = json::array(), units = json::array(), rows = json::array();
    for (int p = 0; p < kNumScmsParams; ++p) {
      names.push_back(kScmsParamInfo[static_cast<std::size_t>(p)].name);
      units.push_back(UnitOf(p));
      json row = json::array();
      for (int q = 0; q < kNumScmsParams; ++q) row.push_back(ToReportUnits(q, ToReportUnits(p, (*cal.covariance)(p, q))));
      rows.push_back(row);
    }
    j["covariance"] = {{"parameters", names}, {"units", units}, {"matrix", rows}};
  }
  j["effects"] = json::array();
  json source = json::object();
  for (const auto& [k, v] : cal.source) source[k] = v;
  j["source"] = source;
  WriteFileAtomically(path, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
}

CalibrationFile ReadCalibrationFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open for reading");
  return ParseCalibration(in, path);
}

CalibrationFile ParseCalibration(std::istream& in, const std::string& path) {
  json j;
  try {
    in >> j;
  } catch (const json::exception& e) {
    throw Error(path + ": not valid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("format") || j["format"] != "sph-calibration") {
    throw Error(path + ": not an sph calibration file (field \"format\" must be \"sph-calibration\")");
  }
  const json& version = Field(j, "format_version", "", path);
  if (!version.is_number_integer() || version.get<int>() != kCalibrationFormatVersion) {
    throw Error(path + ": calibration format version " + version.dump() + " is not supported (this program reads " +
                std::to_string(kCalibrationFormatVersion) + ")");
  }
  CalibrationFile cal;
  cal.probe_offset_mm = Number(j, "probe_offset_mm", "", path);
  if (!(cal.probe_offset_mm > 0.0)) throw Error(path + ": probe_offset_mm must be positive");
  if (j.contains("sphere_radius_mm")) cal.sphere_radius_mm = Number(j, "sphere_radius_mm", "", path);
  if (j.contains("created_by") && j["created_by"].is_string()) cal.created_by = j["created_by"].get<std::string>();
  const json& geometry = Field(j, "geometry", "", path);
  for (int p = 0; p < kNumScmsParams; ++p) {
    const char* name = kScmsParamInfo[static_cast<std::size_t>(p)].name;
    const json& entry = Field(geometry, name, "geometry.", path);
    const std::string where = std::string("geometry.") + name + ".";
    const json& unit = Field(entry, "unit", where, path);
    if (unit != UnitOf(p)) throw Error(path + ": field '" + where + "unit' must be \"" + UnitOf(p) + "\"");
    cal.geometry[static_cast<std::size_t>(p)] = FromReportUnits(p, Number(entry, "value", where, path));
  }
  if (j.contains("covariance")) {
    // The matrix is only meaningful in the order and units it names: they must be the writer's.
    for (const char* key : {"parameters", "units"}) {
      json expected = json::array();
      for (int p = 0; p < kNumScmsParams; ++p) {
        expected.push_back(std::string(key) == "units" ? UnitOf(p) : kScmsParamInfo[static_cast<std::size_t>(p)].name);
      }
      if (Field(j["covariance"], key, "covariance.", path) != expected) {
        throw Error(path + ": field 'covariance." + key + "' must be " + expected.dump());
      }
    }
    const json& rows = Field(j["covariance"], "matrix", "covariance.", path);
    if (!rows.is_array() || rows.size() != kNumScmsParams) throw Error(path + ": covariance.matrix must be 7 x 7");
    Eigen::Matrix<double, kNumScmsParams, kNumScmsParams> c;
    for (int p = 0; p < kNumScmsParams; ++p) {
      const json& row = rows[static_cast<std::size_t>(p)];
      if (!row.is_array() || row.size() != kNumScmsParams) throw Error(path + ": covariance.matrix must be 7 x 7");
      for (int q = 0; q < kNumScmsParams; ++q) {
        const json& v = row[static_cast<std::size_t>(q)];
        if (!v.is_number()) throw Error(path + ": covariance.matrix has a non-number");
        c(p, q) = FromReportUnits(q, FromReportUnits(p, v.get<double>()));
      }
    }
    cal.covariance = c;
  }
  const json& effects = Field(j, "effects", "", path);
  if (!effects.is_array()) throw Error(path + ": field 'effects' must be an array");
  if (!effects.empty()) throw Error(path + ": this program knows no further effects, but the file lists " + std::to_string(effects.size()));
  if (j.contains("source") && j["source"].is_object()) {
    for (const auto& [k, v] : j["source"].items()) cal.source.emplace_back(k, v.is_string() ? v.get<std::string>() : v.dump());
  }
  return cal;
}

Calibration ToCalibration(const CalibrationFile& file) {
  Calibration cal;
  cal.geometry = file.geometry;
  cal.probe_offset_mm = file.probe_offset_mm;
  cal.covariance = file.covariance;
  return cal;
}

Calibration LoadCalibration(const std::string& path) { return ToCalibration(ReadCalibrationFile(path)); }

}  // namespace sph
