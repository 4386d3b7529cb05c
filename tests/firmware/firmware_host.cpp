// The host's side of the firmware tests (tests/firmware/run_cortex_m.sh):
//   firmware_host fixture CALIBRATION OUT_DIR POINTS...   writes OUT_DIR/calibration.c (the library's
//       export of the calibration file) and OUT_DIR/readings.c (every reading of the points files)
//   firmware_host compare CALIBRATION TARGET_OUTPUT POINTS...   compares the target's points with
//       the host's Compensate(), prints the error table and the cost per point; exit 1 on a failure.
// Double: within 1e-9 um of the host (the libm's sin and cos may differ in the last bit). Float:
// within kFloatBoundUm of the host's double over the readings of the examples (see below).
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "sph/core/error.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/firmware_export.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/compensation.hpp"

namespace {

constexpr double kDoubleBoundUm = 1e-9;
// Float: each coordinate is a sum of terms of up to |p| ~ R0 + d ~ 45 mm computed in float, whose
// unit in the last place there is 2^-19 mm = 1.9 nm (3.8 nm above 32 mm); the chain of the model
// (three angle errors, the effects' sums, four rotations) rounds some 30 times, each at most half
// an ulp of the value it rounds: 30 x 0.5 x 3.8 nm = 0.057 um bounds it, and the angles' own
// rounding (theta in rad to 2^-22 = 0.24 urad, 11 nm at 45 mm) is inside that.
constexpr double kFloatBoundUm = 0.06;

struct Reading {
  sph::RawReading raw;
  std::string file;
};

std::vector<Reading> ReadingsOf(char** paths, int n) {
  std::vector<Reading> out;
  for (int i = 0; i < n; ++i) {
    for (const sph::Sample& s : sph::ReadPointsFile(paths[i]).samples) out.push_back({s, paths[i]});
  }
  return out;
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f.flush()) throw sph::Error(path + ": cannot write");
}

int Fixture(const std::string& cal_path, const std::string& dir, const std::vector<Reading>& readings) {
  const sph::Calibration cal = sph::LoadCalibration(cal_path);
  WriteFile(dir + "/calibration.c", sph::FirmwareCSourceOf(cal, "sph_calibration_blob", cal_path));
  std::ostringstream s;
  s << "/* The readings the target compensates (written by firmware_host). */\n#include <stddef.h>\n"
    << "#include \"sph/c/compensation.h\"\n\nconst sph_reading sph_test_readings[] = {\n";
  for (const Reading& r : readings) {
    char line[96];
    std::snprintf(line, sizeof line, "    {%.17g, %.17g, %.17g},\n", r.raw.theta_deg, r.raw.phi_deg, r.raw.r_mm);
    s << line;
  }
  s << "};\nconst size_t sph_test_readings_count = " << readings.size() << ";\n";
  WriteFile(dir + "/readings.c", s.str());
  return 0;
}

double FromBits64(const std::string& hex) {
  const std::uint64_t bits = std::stoull(hex, nullptr, 16);
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

float FromBits32(const std::string& hex) {
  const auto bits = static_cast<std::uint32_t>(std::stoul(hex, nullptr, 16));
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

struct Row {
  std::size_t n = 0, same_bits = 0;
  double theta_min = 1e300, theta_max = -1e300, phi_min = 1e300, phi_max = -1e300, r_min = 1e300, r_max = -1e300;
  double max_double_um = 0.0, max_float_um = 0.0, sum2_float_um = 0.0, max_float_host_um = 0.0;
};

int Compare(const std::string& cal_path, const std::string& target_path, const std::vector<Reading>& readings) {
  const sph::Calibration cal = sph::LoadCalibration(cal_path);
  const sph::BasicCalibration<float> cal_f = sph::CalibrationOf<float>(cal);
  std::ifstream in(target_path);
  if (!in) throw sph::Error(target_path + ": cannot read the target's output");
  std::vector<Eigen::Vector3d> target(readings.size(), Eigen::Vector3d::Constant(NAN));
  std::vector<Eigen::Vector3d> target_f(readings.size(), Eigen::Vector3d::Constant(NAN));
  std::map<std::string, std::uint64_t> counts;
  std::string line;
  bool end = false;
  int failures = 0;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    std::string tag;
    l >> tag;
    if (tag == "D" || tag == "F" || tag == "S") {
      std::string i, x, y, z;
      l >> i >> x >> y >> z;
      const std::size_t k = std::stoul(i, nullptr, 16);
      if (k >= readings.size()) throw sph::Error(target_path + ": point " + i + " beyond the readings");
      if (tag == "D") target[k] = {FromBits64(x), FromBits64(y), FromBits64(z)};
      if (tag == "F") target_f[k] = {FromBits32(x), FromBits32(y), FromBits32(z)};
      if (tag == "S") {
        std::cout << "FAIL: reading " << k << ": sph_compensate() differs from sph_compensate_batch()\n";
        ++failures;
      }
    } else if (tag == "END") {
      end = true;
    } else if (!tag.empty()) {
      l >> counts[tag];
    }
  }
  if (!end) {
    std::cout << "FAIL: the target's output ends before END (" << target_path << ")\n";
    return 1;
  }
  if (counts["READINGS"] != readings.size()) {
    std::cout << "FAIL: the target compensated " << counts["READINGS"] << " readings of " << readings.size() << "\n";
    return 1;
  }
  // sph_status: SPH_ERROR_BLOB_CHECKSUM = 5, SPH_ERROR_NOT_LOADED = 7.
  if (counts["DAMAGED"] != 5 || counts["UNLOADED"] != 7) {
    std::cout << "FAIL: a damaged blob gave status " << counts["DAMAGED"] << " (5 expected), compensating with it "
              << counts["UNLOADED"] << " (7 expected)\n";
    ++failures;
  }
  std::map<std::string, Row> rows;
  Row all;
  for (std::size_t k = 0; k < readings.size(); ++k) {
    const sph::RawReading& r = readings[k].raw;
    const Eigen::Vector3d host = sph::Compensate(cal, r);
    const Eigen::Vector3d host_f =
        sph::Compensate(cal_f, float(r.theta_deg), float(r.phi_deg), float(r.r_mm)).cast<double>();
    const double d_um = (target[k] - host).norm() * 1e3;
    const double f_um = (target_f[k] - host).norm() * 1e3;
    const double fh_um = (target_f[k] - host_f).norm() * 1e3;
    for (Row* row : {&rows[readings[k].file], &all}) {
      ++row->n;
      row->same_bits += target[k] == host ? 1 : 0;
      row->theta_min = std::min(row->theta_min, r.theta_deg);
      row->theta_max = std::max(row->theta_max, r.theta_deg);
      row->phi_min = std::min(row->phi_min, r.phi_deg);
      row->phi_max = std::max(row->phi_max, r.phi_deg);
      row->r_min = std::min(row->r_min, r.r_mm);
      row->r_max = std::max(row->r_max, r.r_mm);
      row->max_double_um = std::max(row->max_double_um, std::isnan(d_um) ? INFINITY : d_um);
      row->max_float_um = std::max(row->max_float_um, std::isnan(f_um) ? INFINITY : f_um);
      row->max_float_host_um = std::max(row->max_float_host_um, std::isnan(fh_um) ? INFINITY : fh_um);
      row->sum2_float_um += f_um * f_um;
    }
  }
  std::printf("%-40s %6s %8s %9s %13s %9s %12s %12s %13s\n", "readings", "n", "theta_deg", "phi_deg", "r_mm",
              "same_bits", "double_um", "float_um", "float_rms_um");
  for (const auto& [name, row] : rows) {
    std::printf("%-40s %6zu %3.0f..%-4.0f %4.1f..%-5.1f %5.3f..%-6.3f %9zu %12.3g %12.4f %13.4f\n", name.c_str(), row.n,
                row.theta_min, row.theta_max, row.phi_min, row.phi_max, row.r_min, row.r_max, row.same_bits,
                row.max_double_um, row.max_float_um, std::sqrt(row.sum2_float_um / double(row.n)));
  }
  std::printf("float on the target against float on the host: max %.4f um\n", all.max_float_host_um);
  // qemu -icount shift=0 advances its virtual clock by 1 ns per instruction, and SysTick counts the
  // board's processor clock in that time: a loop of 2,000,000 instructions on the target gives
  // the instructions per tick.
  if (counts["TICKS_LOOP_2000000"] == 0) {
    std::cout << "FAIL: SysTick did not count (the target's output has no TICKS_LOOP_2000000)\n";
    return 1;
  }
  const double per_tick = 2e6 / double(counts["TICKS_LOOP_2000000"]);
  std::printf(
      "instructions per point (qemu -icount shift=0, SysTick at %.2f instructions per tick): double batch "
      "%.0f, float batch %.0f, double one at a time %.0f\n",
      per_tick, per_tick * double(counts["TICKS_BATCH"]) / double(readings.size()),
      per_tick * double(counts["TICKS_BATCH_F"]) / double(readings.size()),
      per_tick * double(counts["TICKS_SINGLE"]) / double(readings.size()));
  std::printf("stack high-water mark: %" PRIu64 " bytes\n", counts["STACK_BYTES"]);
  if (!(all.max_double_um <= kDoubleBoundUm)) {
    std::cout << "FAIL: double differs from the host by " << all.max_double_um << " um (bound " << kDoubleBoundUm
              << ")\n";
    ++failures;
  }
  if (!(all.max_float_um <= kFloatBoundUm)) {
    std::cout << "FAIL: float differs from the host's double by " << all.max_float_um << " um (bound " << kFloatBoundUm
              << ")\n";
    ++failures;
  }
  std::cout << (failures == 0 ? "firmware: the target's points agree with the host's\n" : "");
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (argc >= 5 && mode == "fixture") return Fixture(argv[2], argv[3], ReadingsOf(argv + 4, argc - 4));
    if (argc >= 5 && mode == "compare") return Compare(argv[2], argv[3], ReadingsOf(argv + 4, argc - 4));
    std::cerr << "usage: firmware_host fixture CALIBRATION OUT_DIR POINTS... | compare CALIBRATION TARGET_OUTPUT "
                 "POINTS...\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "firmware_host: error: " << e.what() << "\n";
    return 2;
  }
}
