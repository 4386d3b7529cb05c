// A calibration as a few hundred bytes for firmware: what compensation needs (the seven errors, d,
// the effects, their normalisation and values), versioned and checked by a CRC-32, so that a target
// that does not parse JSON can load a calibration (sph/c/compensation.h reads it). Header-only, no
// heap, no exceptions. The host writes it from a calibration (sph/io/firmware_export.hpp). Its
// layout, little-endian without padding, every field read byte by byte:
// docs/formats/calibration-files.md#the-firmware-blob. The covariance is not carried.
#ifndef SPH_MODEL_CALIBRATION_BLOB_HPP_
#define SPH_MODEL_CALIBRATION_BLOB_HPP_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "sph/model/compensation.hpp"

namespace sph {

inline constexpr std::uint16_t kCalibrationBlobVersion = 1;
inline constexpr std::size_t kCalibrationBlobHeaderBytes = 136;

/// What reading a blob found.
enum class BlobStatus : int {
  kOk = 0,
  kTooShort,  ///< fewer bytes than its header or its own size field says
  kNotABlob,  ///< no "SPHC" at its start
  kVersion,   ///< a version this library does not read
  kChecksum,  ///< the CRC-32 does not match: damaged in transfer or storage
  kInvalid,   ///< well formed, but no valid calibration (an unknown effect, a component twice,
              ///< a value not finite, d not positive, ...: Calibration::IsValid())
};

namespace internal {
inline std::uint32_t Crc32(const std::uint8_t* bytes, std::size_t n) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= bytes[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}
inline std::uint32_t GetU32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
}
inline double GetF64(const std::uint8_t* p) {
  std::uint64_t bits = 0;
  for (int i = 7; i >= 0; --i) bits = bits << 8 | p[i];
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}
inline std::uint8_t* PutU32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) *p++ = static_cast<std::uint8_t>(v >> (8 * i));
  return p;
}
inline std::uint8_t* PutF64(std::uint8_t* p, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  for (int i = 0; i < 8; ++i) *p++ = static_cast<std::uint8_t>(bits >> (8 * i));
  return p;
}
}  // namespace internal

/// The size of the blob of `cal` [bytes].
template <typename T>
std::size_t CalibrationBlobSize(const BasicCalibration<T>& cal) {
  std::size_t n = kCalibrationBlobHeaderBytes + 4;
  for (const EffectTerm& term : cal.effects.terms) n += 4 + term.components.size() * (4 + 8);
  return n;
}

/// Writes the blob of `cal` (double) to `out`, which has room for CalibrationBlobSize(cal) bytes.
inline void WriteCalibrationBlob(const Calibration& cal, std::uint8_t* out) {
  using internal::PutF64;
  using internal::PutU32;
  std::uint8_t* const start = out;
  const std::size_t size = CalibrationBlobSize(cal);
  *out++ = 'S';
  *out++ = 'P';
  *out++ = 'H';
  *out++ = 'C';
  out = PutU32(out, kCalibrationBlobVersion);
  out = PutU32(out, static_cast<std::uint32_t>(size));
  for (const double v : cal.geometry) out = PutF64(out, v);
  out = PutF64(out, cal.probe_offset_mm);
  const EffectReference& ref = cal.effects.reference;
  for (const double v : {ref.r_ref_mm, ref.r_half_range_mm, ref.t_start_s, ref.t_span_s, ref.r_fit_min_mm,
                         ref.r_fit_max_mm, cal.effects.phi_wobble_pivot_mm}) {
    out = PutF64(out, v);
  }
  out = PutU32(out, static_cast<std::uint32_t>(cal.effects.terms.size()));
  for (std::size_t t = 0; t < cal.effects.terms.size(); ++t) {
    const EffectTerm& term = cal.effects.terms[t];
    *out++ = static_cast<std::uint8_t>(term.effect);
    *out++ = static_cast<std::uint8_t>(term.components.size());
    *out++ = 0;
    *out++ = 0;
    for (const EffectComponent& c : term.components) {
      *out++ = static_cast<std::uint8_t>(c.order);
      *out++ = static_cast<std::uint8_t>(c.axis);
      *out++ = c.sine ? 1 : 0;
      *out++ = 0;
    }
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      out =
          PutF64(out, t < cal.effect_values.size() && i < cal.effect_values[t].size() ? cal.effect_values[t][i] : 0.0);
    }
  }
  PutU32(out, internal::Crc32(start, size - 4));
}

namespace internal {
template <typename T>
BlobStatus ReadBlobInto(const void* blob, std::size_t size, BasicCalibration<T>& out);
}  // namespace internal

/// Reads a blob of `size` bytes into `cal`, in the scalar T (values rounded to it), in place (no
/// copy of the calibration on the stack). Checks the size, magic, version, CRC-32, each term's
/// effect and components against the catalogue, every value against the bounds of the calibration
/// file (the seven errors' ScmsParamInfo::max_abs_report, d and the lengths within kMaxPivotMm,
/// the effects' kMaxEffectArcsec and kMaxEffectUm), and then Calibration::IsValid(). Any result but
/// kOk leaves `cal` empty and invalid (d = 0), so that compensating with it gives NaN.
template <typename T>
BlobStatus ReadCalibrationBlob(const void* blob, std::size_t size, BasicCalibration<T>* cal) {
  const BlobStatus status = internal::ReadBlobInto(blob, size, *cal);
  if (status != BlobStatus::kOk) {
    cal->geometry = {};
    cal->probe_offset_mm = T(0.0);
    cal->covariance.reset();
    cal->effects.terms.clear();
    cal->effects.reference = EffectReference{};
    cal->effects.phi_wobble_pivot_mm = 0.0;
    cal->effect_values.clear();
  }
  return status;
}

namespace internal {
template <typename T>
BlobStatus ReadBlobInto(const void* blob, std::size_t size, BasicCalibration<T>& out) {
  const auto* p = static_cast<const std::uint8_t*>(blob);
  if (p == nullptr || size < kCalibrationBlobHeaderBytes + 4) return BlobStatus::kTooShort;
  if (std::memcmp(p, "SPHC", 4) != 0) return BlobStatus::kNotABlob;
  if (GetU32(p + 4) != kCalibrationBlobVersion) return BlobStatus::kVersion;
  const std::uint32_t declared = GetU32(p + 8);
  if (declared < kCalibrationBlobHeaderBytes + 4 || declared > size) return BlobStatus::kTooShort;
  if (GetU32(p + declared - 4) != internal::Crc32(p, declared - 4)) return BlobStatus::kChecksum;
  const std::uint8_t* const end = p + declared - 4;
  out.covariance.reset();
  out.effects.terms.clear();
  out.effect_values.clear();
  // Every value within what the calibration file accepts (sph/io/calibration_file.hpp), so that
  // no finite but absurd value reaches the model: an error of a working machine, not another one.
  const auto within = [](double v, double bound) { return std::abs(v) <= bound; };  // false for NaN
  const std::uint8_t* q = p + 12;
  for (std::size_t i = 0; i < out.geometry.size(); ++i, q += 8) {
    const ScmsParamInfo& info = kScmsParamInfo[i];
    const double v = GetF64(q);
    if (!within(v, info.max_abs_report * (info.quantity == Quantity::kAngle ? kRadPerDeg : 1.0))) {
      return BlobStatus::kInvalid;
    }
    out.geometry[i] = T(v);
  }
  const double d = GetF64(q);
  q += 8;
  if (!(d > 0.0 && d <= kMaxPivotMm)) return BlobStatus::kInvalid;
  out.probe_offset_mm = T(d);
  EffectReference& ref = out.effects.reference;
  for (double* v : {&ref.r_ref_mm, &ref.r_half_range_mm, &ref.t_start_s, &ref.t_span_s, &ref.r_fit_min_mm,
                    &ref.r_fit_max_mm, &out.effects.phi_wobble_pivot_mm}) {
    *v = GetF64(q);
    q += 8;
  }
  for (const double v : {ref.r_ref_mm, ref.r_half_range_mm, out.effects.phi_wobble_pivot_mm}) {
    if (!within(v, kMaxPivotMm)) return BlobStatus::kInvalid;
  }
  for (const double v : {ref.r_fit_min_mm, ref.r_fit_max_mm}) {
    if (!std::isnan(v) && !within(v, kMaxPivotMm)) return BlobStatus::kInvalid;
  }
  const std::uint32_t num_terms = GetU32(q);
  q += 4;
  if (num_terms > static_cast<std::uint32_t>(kNumEffects)) return BlobStatus::kInvalid;
  for (std::uint32_t t = 0; t < num_terms; ++t) {
    if (end - q < 4) return BlobStatus::kTooShort;
    const int effect = q[0];
    const std::size_t n = q[1];
    q += 4;
    if (effect >= kNumEffects || n == 0 || n > kMaxTermComponents) return BlobStatus::kInvalid;
    if (static_cast<std::size_t>(end - q) < n * (4 + 8)) return BlobStatus::kTooShort;
    EffectTerm term;
    term.effect = static_cast<Effect>(effect);
    const EffectTerm catalogue = DefaultTerm(term.effect, kMaxEffectHarmonic, kMaxDriftOrder);
    for (std::size_t i = 0; i < n; ++i, q += 4) {
      const EffectComponent c{q[0], q[1], q[2] != 0};
      // Only a component the catalogue names (probe_incidence: the powers 1 to kMaxIncidenceOrder), once.
      bool known = term.effect == Effect::kProbeIncidence
                       ? c.order >= 1 && c.order <= kMaxIncidenceOrder && c.axis == 0 && !c.sine
                       : false;
      for (const EffectComponent& k : catalogue.components) {
        known = known || (k.order == c.order && k.axis == c.axis && k.sine == c.sine);
      }
      for (const EffectComponent& k : term.components) {
        if (k.order == c.order && k.axis == c.axis && k.sine == c.sine) known = false;
      }
      if (!known || q[2] > 1 || q[3] != 0) return BlobStatus::kInvalid;
      term.components.push_back(c);
    }
    if (out.effects.Find(term.effect) >= 0) return BlobStatus::kInvalid;
    out.effects.terms.push_back(term);
    out.effect_values.emplace_back();
    const double bound =
        term.info().quantity == Quantity::kAngle ? kMaxEffectArcsec * kRadPerArcsec : kMaxEffectUm * kMmPerUm;
    for (std::size_t i = 0; i < n; ++i, q += 8) {
      const double v = GetF64(q);
      if (!within(v, bound)) return BlobStatus::kInvalid;
      out.effect_values.back().push_back(T(v));
    }
  }
  return q == end && out.IsValid() ? BlobStatus::kOk : BlobStatus::kInvalid;
}
}  // namespace internal

}  // namespace sph

#endif  // SPH_MODEL_CALIBRATION_BLOB_HPP_
