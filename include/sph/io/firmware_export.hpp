// A calibration for firmware: the blob that the C interface loads (sph/c/compensation.h; layout in
// sph/model/calibration_blob.hpp), as bytes or as a C99 source of constants, written from a
// calibration or a calibration file. The host's side of docs/library.md#firmware.
#ifndef SPH_IO_FIRMWARE_EXPORT_HPP_
#define SPH_IO_FIRMWARE_EXPORT_HPP_

#include <cstdint>
#include <string>
#include <vector>

#include "sph/model/compensation.hpp"

namespace sph {

/// The firmware blob of `cal` (its covariance is not carried). Throws sph::Error when `cal` is not
/// valid (Calibration::IsValid()).
std::vector<std::uint8_t> FirmwareBlobOf(const Calibration& cal);

/// A C99 source that defines the blob of `cal` as `const unsigned char <symbol>[]` and its length
/// as `const size_t <symbol>_size`, with a comment that lists the calibration in report units (deg,
/// mm, arcsec, um) and names `source` (what it was made from: a calibration file, or the points
/// file of a calibration). `symbol`: a C identifier. Throws sph::Error when `cal` is not valid or `symbol` is no
/// identifier.
std::string FirmwareCSourceOf(const Calibration& cal, const std::string& symbol, const std::string& source);

/// What ExportFirmwareCalibration() writes: the blob's file and/or the C source's ("" for none).
struct FirmwareExportPaths {
  std::string blob_path;
  std::string c_source_path;
  std::string symbol = "sph_calibration_blob";  ///< the C source's array
};

class OutputFiles;

/// Stages the blob and/or the C source of `cal` into `files` (sph/io/output_files.hpp), the C
/// source naming `source`. Throws sph::Error as FirmwareBlobOf() and FirmwareCSourceOf() do.
void StageFirmwareExport(const Calibration& cal, const FirmwareExportPaths& out, const std::string& source,
                         OutputFiles& files);

/// Reads the calibration file at `calibration_path` (LoadCalibration()) and writes the blob and/or
/// the C source, each complete or not at all (OutputFiles); never over the calibration file.
/// Throws sph::Error naming the file and the problem.
void ExportFirmwareCalibration(const std::string& calibration_path, const FirmwareExportPaths& out);

}  // namespace sph

#endif  // SPH_IO_FIRMWARE_EXPORT_HPP_
