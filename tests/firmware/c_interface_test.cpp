// The C interface (sph/c/compensation.h) and the firmware export (sph/io/firmware_export.hpp) on
// the host: the same points as the C++ Compensate(), every error code, the blob read back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "sph/c/compensation.h"
#include "sph/core/error.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/firmware_export.hpp"
#include "sph/model/calibration_blob.hpp"
#include "sph/model/compensation.hpp"

extern "C" int sph_c99_compensate(const unsigned char* blob, size_t size, double theta_deg, double phi_deg, double r_mm,
                                  double out_mm[3]);

namespace sph {
namespace {

// A calibration with every effect of the catalogue but probe_drift, and a form (which compensation
// does not apply): tests/firmware/calibration.json.
const Calibration& TestCalibration() {
  static const Calibration cal = LoadCalibration(SPH_FIRMWARE_CALIBRATION);
  return cal;
}

std::vector<RawReading> Grid() {
  std::vector<RawReading> readings;
  for (double theta = 0.0; theta < 360.0; theta += 37.5) {
    for (double phi = 7.5; phi <= 172.5; phi += 25.0) readings.push_back({theta, phi, 2.0 + theta / 60.0});
  }
  return readings;
}

std::vector<std::uint8_t> Blob() { return FirmwareBlobOf(TestCalibration()); }

/// `blob` with its CRC-32 made right again after a change.
void Reseal(std::vector<std::uint8_t>& blob) {
  internal::PutU32(blob.data() + blob.size() - 4, internal::Crc32(blob.data(), blob.size() - 4));
}

sph_status Load(const std::vector<std::uint8_t>& blob, sph_calibration* cal) {
  return sph_calibration_load(cal, blob.data(), blob.size());
}

TEST(CInterface, CompensatesAsTheCppLibraryToTheLastBit) {
  auto cal = std::make_unique<sph_calibration>();
  ASSERT_EQ(Load(Blob(), cal.get()), SPH_OK);
  ASSERT_GT(TestCalibration().effects.terms.size(), 10u);
  const std::vector<RawReading> grid = Grid();
  std::vector<sph_reading> readings;
  for (const RawReading& r : grid) readings.push_back({r.theta_deg, r.phi_deg, r.r_mm});
  std::vector<sph_point> batch(readings.size());
  ASSERT_EQ(sph_compensate_batch(cal.get(), readings.data(), readings.size(), batch.data()), SPH_OK);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const Eigen::Vector3d expected = Compensate(TestCalibration(), grid[i]);
    sph_point one;
    ASSERT_EQ(sph_compensate(cal.get(), &readings[i], &one), SPH_OK);
    EXPECT_EQ(one.x_mm, expected[0]);
    EXPECT_EQ(one.y_mm, expected[1]);
    EXPECT_EQ(one.z_mm, expected[2]);
    EXPECT_EQ(std::memcmp(&one, &batch[i], sizeof one), 0);
  }
}

TEST(CInterface, CompensatesInFloatAsTheCppLibraryInFloat) {
  auto cal = std::make_unique<sph_calibration_f>();
  const std::vector<std::uint8_t> blob = Blob();
  ASSERT_EQ(sph_calibration_load_f(cal.get(), blob.data(), blob.size()), SPH_OK);
  const BasicCalibration<float> cal_f = CalibrationOf<float>(TestCalibration());
  for (const RawReading& r : Grid()) {
    const sph_reading_f reading{float(r.theta_deg), float(r.phi_deg), float(r.r_mm)};
    sph_point_f p;
    ASSERT_EQ(sph_compensate_f(cal.get(), &reading, &p), SPH_OK);
    const Vec3<float> expected = Compensate(cal_f, reading.theta_deg, reading.phi_deg, reading.r_mm);
    EXPECT_EQ(p.x_mm, expected[0]);
    EXPECT_EQ(p.y_mm, expected[1]);
    EXPECT_EQ(p.z_mm, expected[2]);
    // Against double: the float error stays far below the probe's noise (see docs/library.md).
    const Eigen::Vector3d exact = Compensate(TestCalibration(), r);
    EXPECT_LT((expected.cast<double>() - exact).norm() * kUmPerMm, 0.06);
  }
}

TEST(CInterface, IsUsableFromC99) {
  const std::vector<std::uint8_t> blob = Blob();
  double out[3];
  ASSERT_EQ(sph_c99_compensate(blob.data(), blob.size(), 30.0, 60.0, 5.1, out), 0);
  const Eigen::Vector3d expected = Compensate(TestCalibration(), 30.0, 60.0, 5.1);
  EXPECT_EQ(out[0], expected[0]);
  EXPECT_EQ(out[1], expected[1]);
  EXPECT_EQ(out[2], expected[2]);
}

TEST(CInterface, NamesEachFaultOfABlob) {
  auto cal = std::make_unique<sph_calibration>();
  const std::vector<std::uint8_t> good = Blob();
  std::vector<std::uint8_t> b = good;
  EXPECT_EQ(sph_calibration_load(cal.get(), b.data(), 100), SPH_ERROR_BLOB_SHORT);
  EXPECT_EQ(sph_calibration_load(cal.get(), b.data(), b.size() - 1), SPH_ERROR_BLOB_SHORT);
  b[0] = 'X';
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_FORMAT);
  b = good;
  b[4] = 2;
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_VERSION);
  b = good;
  b[20] ^= 0x10;  // a bit of alpha
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_CHECKSUM);
  b = good;
  internal::PutF64(b.data() + 68, 0.0);  // d = 0, resealed: well formed, not valid
  Reseal(b);
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_INVALID);
  b = good;
  internal::PutF64(b.data() + 12, 1.0);  // alpha 1 rad (57 deg): beyond the 10 deg a calibration file takes
  Reseal(b);
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_INVALID);
  b = good;
  b[kCalibrationBlobHeaderBytes] = 7;  // the first term made a probe_drift
  Reseal(b);
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_INVALID);
  b = good;
  b[kCalibrationBlobHeaderBytes + 4] = 13;  // the first term's first component an order beyond the catalogue
  Reseal(b);
  EXPECT_EQ(Load(b, cal.get()), SPH_ERROR_BLOB_INVALID);
  // A failed load leaves the calibration unusable, not half loaded.
  sph_reading r{30.0, 60.0, 5.0};
  sph_point p;
  EXPECT_EQ(sph_compensate(cal.get(), &r, &p), SPH_ERROR_NOT_LOADED);
  EXPECT_STREQ(sph_status_text(SPH_ERROR_BLOB_CHECKSUM),
               "the calibration blob's CRC-32 does not match: damaged in transfer or storage");
}

TEST(CInterface, RefusesNullsAndAnUnloadedCalibrationAndMarksAReadingNotFinite) {
  auto cal = std::make_unique<sph_calibration>();
  std::memset(cal.get(), 0, sizeof *cal);
  sph_reading r{30.0, 60.0, 5.0};
  sph_point p;
  EXPECT_EQ(sph_compensate(cal.get(), &r, &p), SPH_ERROR_NOT_LOADED);
  EXPECT_EQ(sph_calibration_load(nullptr, nullptr, 0), SPH_ERROR_ARGUMENT);
  EXPECT_EQ(sph_calibration_load(cal.get(), nullptr, 0), SPH_ERROR_ARGUMENT);
  ASSERT_EQ(Load(Blob(), cal.get()), SPH_OK);
  EXPECT_EQ(sph_compensate(nullptr, &r, &p), SPH_ERROR_ARGUMENT);
  EXPECT_EQ(sph_compensate(cal.get(), nullptr, &p), SPH_ERROR_ARGUMENT);
  EXPECT_EQ(sph_compensate_batch(cal.get(), nullptr, 0, nullptr), SPH_OK);
  const sph_reading two[2] = {{30.0, std::nan(""), 5.0}, {30.0, 60.0, 5.0}};
  sph_point out[2];
  EXPECT_EQ(sph_compensate_batch(cal.get(), two, 2, out), SPH_ERROR_READING);
  EXPECT_TRUE(std::isnan(out[0].x_mm) && std::isnan(out[0].y_mm) && std::isnan(out[0].z_mm));
  EXPECT_EQ(out[1].x_mm, Compensate(TestCalibration(), 30.0, 60.0, 5.0)[0]);
}

TEST(CalibrationBlob, ReadsBackWhatWasWritten) {
  const Calibration& cal = TestCalibration();
  const std::vector<std::uint8_t> blob = Blob();
  auto back = std::make_unique<Calibration>();
  ASSERT_EQ(ReadCalibrationBlob(blob.data(), blob.size(), back.get()), BlobStatus::kOk);
  EXPECT_EQ(back->geometry, cal.geometry);
  EXPECT_EQ(back->probe_offset_mm, cal.probe_offset_mm);
  ASSERT_EQ(back->effects.terms.size(), cal.effects.terms.size());
  for (std::size_t t = 0; t < cal.effects.terms.size(); ++t) {
    EXPECT_EQ(back->effects.terms[t].effect, cal.effects.terms[t].effect);
    for (std::size_t i = 0; i < cal.effects.terms[t].components.size(); ++i) {
      EXPECT_EQ(back->effects.terms[t].ParamName(i), cal.effects.terms[t].ParamName(i));
    }
  }
  EXPECT_TRUE(back->effect_values == cal.effect_values);
  EXPECT_EQ(back->effects.phi_wobble_pivot_mm, 80.0);
  EXPECT_EQ(back->effects.reference.r_ref_mm, cal.effects.reference.r_ref_mm);
  EXPECT_FALSE(back->covariance.has_value());
  // Header, per term 4 bytes and 12 per component, the CRC.
  std::size_t components = 0;
  for (const EffectTerm& t : cal.effects.terms) components += t.components.size();
  EXPECT_EQ(blob.size(), kCalibrationBlobHeaderBytes + 4 * cal.effects.terms.size() + 12 * components + 4);
}

TEST(FirmwareExport, WritesTheBlobAndACSourceOfItAndNeverOverTheInput) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "sph_firmware_export";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string bin = (dir / "cal.bin").string(), c = (dir / "cal.c").string();
  ExportFirmwareCalibration(SPH_FIRMWARE_CALIBRATION, {bin, c, "machine_7"});
  std::ifstream f(bin, std::ios::binary);
  const std::vector<std::uint8_t> written((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_EQ(written, Blob());
  std::ifstream cs(c);
  const std::string source((std::istreambuf_iterator<char>(cs)), std::istreambuf_iterator<char>());
  EXPECT_NE(source.find("const unsigned char machine_7[" + std::to_string(written.size()) + "] = {"),
            std::string::npos);
  EXPECT_NE(source.find("const size_t machine_7_size = " + std::to_string(written.size()) + ";"), std::string::npos);
  EXPECT_NE(source.find("phi_wobble.x_c2 = 2 arcsec"), std::string::npos);
  EXPECT_THROW(ExportFirmwareCalibration(SPH_FIRMWARE_CALIBRATION, {SPH_FIRMWARE_CALIBRATION, "", "x"}), Error);
  EXPECT_THROW(FirmwareCSourceOf(TestCalibration(), "2cal", "here"), Error);
  EXPECT_THROW(ExportFirmwareCalibration((dir / "missing.json").string(), {bin, "", "x"}), Error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sph
