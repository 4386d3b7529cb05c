// libFuzzer target: the firmware's calibration blob (sph::ReadCalibrationBlob(), which
// sph_calibration_load() of sph/c/compensation.h calls) on arbitrary bytes, in double and float.
// A blob the reader takes must be a valid calibration that compensates to finite points; one it
// refuses must leave the calibration invalid. The CRC is made right for half the inputs, so that
// the fuzzer reaches the content's checks behind it.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#include "sph/model/calibration_blob.hpp"

namespace {

template <typename T>
void Check(const std::uint8_t* data, std::size_t size) {
  static auto cal = std::make_unique<sph::BasicCalibration<T>>();
  const sph::BlobStatus status = sph::ReadCalibrationBlob(data, size, cal.get());
  if (status != sph::BlobStatus::kOk) {
    if (cal->IsValid()) std::abort();  // a refused blob leaves no usable calibration
    return;
  }
  if (!cal->IsValid()) std::abort();
  for (const T theta : {T(0), T(123.4)}) {
    const sph::Vec3<T> p = sph::Compensate(*cal, theta, T(45), T(5));
    if (!p.allFinite()) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Check<double>(data, size);
  Check<float>(data, size);
  if (size >= sph::kCalibrationBlobHeaderBytes + 4 && size % 2 == 0) {
    // The same bytes with their size field and CRC-32 made right.
    std::vector<std::uint8_t> sealed(data, data + size);
    sph::internal::PutU32(sealed.data() + 8, static_cast<std::uint32_t>(size));
    sph::internal::PutU32(sealed.data() + size - 4, sph::internal::Crc32(sealed.data(), size - 4));
    Check<double>(sealed.data(), sealed.size());
    Check<float>(sealed.data(), sealed.size());
  }
  return 0;
}
