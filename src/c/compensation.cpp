// The C interface of sph/c/compensation.h over sph/model/compensation.hpp: no heap, no exceptions,
// no RTTI needed (it builds with -fno-exceptions -fno-rtti for bare-metal targets).
#include "sph/c/compensation.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <new>

#include "sph/model/calibration_blob.hpp"
#include "sph/model/compensation.hpp"

namespace {

constexpr std::uint32_t kLoadedTag = 0x4C485053u;  // "SPHL"

/// What a sph_calibration holds once loaded: the calibration and its angle errors' trig.
template <typename T>
struct Loaded {
  std::uint32_t tag = 0;
  sph::BasicCalibration<T> cal;
  sph::ScmsErrorTrig<T> trig{};
};

static_assert(sizeof(Loaded<double>) <= sizeof(sph_calibration::storage.bytes), "SPH_CALIBRATION_BYTES too small");
static_assert(sizeof(Loaded<float>) <= sizeof(sph_calibration_f::storage.bytes), "SPH_CALIBRATION_BYTES too small");
static_assert(alignof(Loaded<double>) <= alignof(sph_calibration), "sph_calibration aligned too loosely");
static_assert(alignof(Loaded<float>) <= alignof(sph_calibration_f), "sph_calibration_f aligned too loosely");

sph_status StatusOf(sph::BlobStatus s) {
  switch (s) {
    case sph::BlobStatus::kOk:
      return SPH_OK;
    case sph::BlobStatus::kTooShort:
      return SPH_ERROR_BLOB_SHORT;
    case sph::BlobStatus::kNotABlob:
      return SPH_ERROR_BLOB_FORMAT;
    case sph::BlobStatus::kVersion:
      return SPH_ERROR_BLOB_VERSION;
    case sph::BlobStatus::kChecksum:
      return SPH_ERROR_BLOB_CHECKSUM;
    case sph::BlobStatus::kInvalid:
      break;
  }
  return SPH_ERROR_BLOB_INVALID;
}

template <typename T, typename Storage>
sph_status Load(Storage* storage, const void* blob, std::size_t size) {
  if (storage == nullptr) return SPH_ERROR_ARGUMENT;
  auto* loaded = new (storage->storage.bytes) Loaded<T>;  // placement: no allocation
  const sph_status status =
      blob == nullptr ? SPH_ERROR_ARGUMENT : StatusOf(sph::ReadCalibrationBlob(blob, size, &loaded->cal));
  if (status == SPH_OK) {
    loaded->trig = sph::ErrorTrigOf(loaded->cal.geometry.data());
    loaded->tag = kLoadedTag;
  }
  return status;
}

/// The loaded calibration of `storage`, or nullptr (never loaded: its bytes are not a Loaded<T>).
template <typename T, typename Storage>
const Loaded<T>* LoadedOf(const Storage* storage) {
  if (storage == nullptr) return nullptr;
  std::uint32_t tag;
  std::memcpy(&tag, storage->storage.bytes, sizeof tag);
  if (tag != kLoadedTag) return nullptr;
  return std::launder(reinterpret_cast<const Loaded<T>*>(storage->storage.bytes));
}

template <typename T, typename Reading, typename Point>
sph_status CompensateBatch(const Loaded<T>& l, const Reading* readings, std::size_t count, Point* points) {
  const sph::internal::BasicCompensationContext<T> ctx(l.cal, l.trig, true);
  sph_status status = SPH_OK;
  for (std::size_t i = 0; i < count; ++i) {
    const Reading& r = readings[i];
    if (!std::isfinite(r.theta_deg) || !std::isfinite(r.phi_deg) || !std::isfinite(r.r_mm)) {
      const T nan = std::numeric_limits<T>::quiet_NaN();
      points[i] = Point{nan, nan, nan};
      status = SPH_ERROR_READING;
      continue;
    }
    const sph::Vec3<T> p =
        sph::internal::CompensateWith(l.cal, ctx, sph::BasicEffectReading<T>(r.theta_deg, r.phi_deg, r.r_mm, T(0.0)));
    points[i] = Point{p[0], p[1], p[2]};
  }
  return status;
}

template <typename T, typename Storage, typename Reading, typename Point>
sph_status Compensate(const Storage* cal, const Reading* readings, std::size_t count, Point* points) {
  if (cal == nullptr || (count > 0 && (readings == nullptr || points == nullptr))) return SPH_ERROR_ARGUMENT;
  const Loaded<T>* l = LoadedOf<T>(cal);
  if (l == nullptr) return SPH_ERROR_NOT_LOADED;
  return CompensateBatch(*l, readings, count, points);
}

}  // namespace

extern "C" {

sph_status sph_calibration_load(sph_calibration* cal, const void* blob, size_t size) {
  return Load<double>(cal, blob, size);
}

sph_status sph_calibration_load_f(sph_calibration_f* cal, const void* blob, size_t size) {
  return Load<float>(cal, blob, size);
}

sph_status sph_compensate(const sph_calibration* cal, const sph_reading* reading, sph_point* point) {
  if (reading == nullptr || point == nullptr) return SPH_ERROR_ARGUMENT;
  return Compensate<double>(cal, reading, 1, point);
}

sph_status sph_compensate_batch(const sph_calibration* cal, const sph_reading* readings, size_t count,
                                sph_point* points) {
  return Compensate<double>(cal, readings, count, points);
}

sph_status sph_compensate_f(const sph_calibration_f* cal, const sph_reading_f* reading, sph_point_f* point) {
  if (reading == nullptr || point == nullptr) return SPH_ERROR_ARGUMENT;
  return Compensate<float>(cal, reading, 1, point);
}

sph_status sph_compensate_batch_f(const sph_calibration_f* cal, const sph_reading_f* readings, size_t count,
                                  sph_point_f* points) {
  return Compensate<float>(cal, readings, count, points);
}

const char* sph_status_text(sph_status status) {
  switch (status) {
    case SPH_OK:
      return "ok";
    case SPH_ERROR_ARGUMENT:
      return "a null pointer was passed";
    case SPH_ERROR_BLOB_SHORT:
      return "the calibration blob is shorter than its header or its size field says";
    case SPH_ERROR_BLOB_FORMAT:
      return "no calibration blob (\"SPHC\" missing at its start)";
    case SPH_ERROR_BLOB_VERSION:
      return "a version of the calibration blob this library does not read";
    case SPH_ERROR_BLOB_CHECKSUM:
      return "the calibration blob's CRC-32 does not match: damaged in transfer or storage";
    case SPH_ERROR_BLOB_INVALID:
      return "the calibration blob holds no valid calibration";
    case SPH_ERROR_NOT_LOADED:
      return "the calibration was never loaded, or its load failed";
    case SPH_ERROR_READING:
      return "a reading was not finite: its point is NaN";
  }
  return "unknown status";
}

}  // extern "C"
