#include "sph/io/firmware_export.hpp"

#include <cctype>
#include <sstream>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/output_files.hpp"
#include "sph/model/calibration_blob.hpp"

namespace sph {

namespace {

using internal::Format;

bool IsCIdentifier(const std::string& s) {
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
  for (const char c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

/// The calibration in report units, one line each, for the C source's comment.
std::string Listing(const Calibration& cal) {
  std::ostringstream s;
  for (int i = 0; i < kNumScmsParams; ++i) {
    const ReportUnits u = ReportUnitsOf(i);
    s << " *   " << kScmsParamInfo[static_cast<std::size_t>(i)].name << " = "
      << Format("%.17g", ToReportUnits(i, cal.geometry[static_cast<std::size_t>(i)])) << " " << u.coarse << "\n";
  }
  s << " *   probe_offset_mm = " << Format("%.17g", cal.probe_offset_mm) << "\n";
  if (cal.effects.Empty()) return s.str();
  const EffectReference& r = cal.effects.reference;
  s << " *   reference: r_ref_mm = " << Format("%.17g", r.r_ref_mm)
    << ", r_half_range_mm = " << Format("%.17g", r.r_half_range_mm) << "\n";
  for (std::size_t t = 0; t < cal.effects.terms.size(); ++t) {
    const EffectTerm& term = cal.effects.terms[t];
    const bool angle = term.info().quantity == Quantity::kAngle;
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      const double v = cal.effect_values[t][i] / (angle ? kRadPerArcsec : kMmPerUm);
      s << " *   " << term.ParamName(i) << " = " << Format("%.17g", v) << (angle ? " arcsec" : " um") << "\n";
    }
    if (term.effect == Effect::kPhiWobble) {
      s << " *   phi_wobble pivot_mm = " << Format("%.17g", cal.effects.phi_wobble_pivot_mm) << "\n";
    }
  }
  return s.str();
}

}  // namespace

std::vector<std::uint8_t> FirmwareBlobOf(const Calibration& cal) {
  if (!cal.IsValid()) throw Error("the calibration is not valid: it cannot be exported for firmware");
  std::vector<std::uint8_t> blob(CalibrationBlobSize(cal));
  WriteCalibrationBlob(cal, blob.data());
  return blob;
}

std::string FirmwareCSourceOf(const Calibration& cal, const std::string& symbol, const std::string& source) {
  if (!IsCIdentifier(symbol)) throw Error("'" + symbol + "' is no C identifier: the C source's array needs one");
  const std::vector<std::uint8_t> blob = FirmwareBlobOf(cal);
  std::ostringstream s;
  s << "/* A calibration for sph/c/compensation.h: load it with\n"
    << " *   sph_calibration_load(&cal, " << symbol << ", " << symbol << "_size);\n"
    << " * Written by sph from " << source << " (blob format " << kCalibrationBlobVersion << ", " << blob.size()
    << " bytes, CRC-32 checked on loading). Its values (deg, mm, arcsec, um):\n"
    << Listing(cal) << " */\n"
    << "#include <stddef.h>\n\n"
    << "extern const unsigned char " << symbol << "[];\n"
    << "extern const size_t " << symbol << "_size;\n\n"
    << "const unsigned char " << symbol << "[" << blob.size() << "] = {";
  for (std::size_t i = 0; i < blob.size(); ++i) {
    s << (i % 12 == 0 ? "\n    " : " ") << Format("0x%02x", blob[i]) << (i + 1 < blob.size() ? "," : "");
  }
  s << "\n};\n"
    << "const size_t " << symbol << "_size = " << blob.size() << ";\n";
  return s.str();
}

void StageFirmwareExport(const Calibration& cal, const FirmwareExportPaths& out, const std::string& source,
                         OutputFiles& files) {
  if (!out.blob_path.empty()) {
    const std::vector<std::uint8_t> blob = FirmwareBlobOf(cal);
    files.Stage(out.blob_path, [&](std::ostream& f) {
      f.write(reinterpret_cast<const char*>(blob.data()), static_cast<std::streamsize>(blob.size()));
    });
  }
  if (!out.c_source_path.empty()) {
    const std::string text = FirmwareCSourceOf(cal, out.symbol, source);
    files.Stage(out.c_source_path, [&](std::ostream& f) { f << text; });
  }
}

void ExportFirmwareCalibration(const std::string& calibration_path, const FirmwareExportPaths& out) {
  if (out.blob_path.empty() && out.c_source_path.empty()) throw Error("no output for the firmware export named");
  RunPaths paths;
  paths.Input("calibration", calibration_path);
  if (!out.blob_path.empty()) paths.Output("--firmware-blob", out.blob_path);
  if (!out.c_source_path.empty()) paths.Output("--firmware-c", out.c_source_path);
  const Calibration cal = LoadCalibration(calibration_path);
  if (!cal.IsValid())
    throw Error(calibration_path + ": the calibration is not valid: it cannot be exported for firmware");
  OutputFiles files;
  StageFirmwareExport(cal, out, calibration_path, files);
  files.Commit();
}

}  // namespace sph
