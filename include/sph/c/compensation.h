/* Compensation from C (C99 and later, and C++): raw SCMS readings to coordinates in the sphere
 * frame with a calibration loaded from its blob, without the heap, exceptions or JSON. What
 * firmware links (library sph::c); the C++ it wraps is sph/model/compensation.hpp.
 *
 * A calibration reaches the target as a blob: `sph_calibrate -o cal.json --firmware-blob cal.bin`,
 * or the same bytes as a C source of constants (`--firmware-c cal.c`), both written from a
 * calibration file by sph::ExportFirmwareCalibration() too (sph/io/firmware_export.hpp); its
 * layout: sph/model/calibration_blob.hpp. sph_calibration_load() checks its version, size, CRC-32
 * and content, and fills a caller's sph_calibration (static storage, a few kB: no allocation).
 *
 * Units: readings theta_deg, phi_deg [deg] and r_mm [mm] as the machine gives them; points [mm] in
 * the frame that turns with Theta (where the measured sphere is at rest). Applied: the seven errors
 * and every effect of the calibration but probe_incidence, whose angle needs the measured sphere's
 * centre (the C++ CompensateAll() with a centre applies it); a probe drift and the sphere's form
 * are never part of a calibration. The *_f functions compute in float (a calibration loaded with
 * sph_calibration_load_f()), for targets whose floating-point unit has single precision only:
 * their error against double over the working range is in docs/library.md.
 *
 * Thread safety: a loaded calibration is only read by the compensate functions. */
#ifndef SPH_C_COMPENSATION_H_
#define SPH_C_COMPENSATION_H_

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/** What a call did. */
typedef enum sph_status {
  SPH_OK = 0,
  SPH_ERROR_ARGUMENT = 1,      /**< a null pointer */
  SPH_ERROR_BLOB_SHORT = 2,    /**< the blob is shorter than its header or its own size field says */
  SPH_ERROR_BLOB_FORMAT = 3,   /**< no calibration blob ("SPHC" missing) */
  SPH_ERROR_BLOB_VERSION = 4,  /**< a version of the blob this library does not read */
  SPH_ERROR_BLOB_CHECKSUM = 5, /**< its CRC-32 does not match: damaged in transfer or storage */
  SPH_ERROR_BLOB_INVALID = 6,  /**< well formed, but no valid calibration */
  SPH_ERROR_NOT_LOADED = 7,    /**< the calibration was never loaded, or its load failed */
  SPH_ERROR_READING = 8        /**< a reading not finite: its point is NaN */
} sph_status;

/** One reading as the machine gives it. */
typedef struct sph_reading {
  double theta_deg; /**< Theta axis [deg] */
  double phi_deg;   /**< Phi axis [deg] */
  double r_mm;      /**< probe [mm] */
} sph_reading;

/** A compensated point [mm], sphere frame. */
typedef struct sph_point {
  double x_mm, y_mm, z_mm;
} sph_point;

typedef struct sph_reading_f {
  float theta_deg, phi_deg, r_mm;
} sph_reading_f;

typedef struct sph_point_f {
  float x_mm, y_mm, z_mm;
} sph_point_f;

/** Room for a loaded calibration [bytes]: the seven errors, the effects (at most one term per
 * effect, bounded by the effect catalogue) and their values. Checked against the C++ type at
 * compile time. */
#define SPH_CALIBRATION_BYTES 16384

/** A loaded calibration (double). Opaque: fill it with sph_calibration_load(). It holds no pointer
 * into the blob, which may go after loading. */
typedef struct sph_calibration {
  union {
    double align_double;
    long long align_long;
    void* align_pointer;
    unsigned char bytes[SPH_CALIBRATION_BYTES];
  } storage;
} sph_calibration;

/** A loaded calibration for float compensation. Opaque: fill it with sph_calibration_load_f(). */
typedef struct sph_calibration_f {
  union {
    double align_double;
    long long align_long;
    void* align_pointer;
    unsigned char bytes[SPH_CALIBRATION_BYTES];
  } storage;
} sph_calibration_f;

/** Loads the calibration blob of `size` bytes into `cal`. Any status but SPH_OK leaves `cal` not
 * loaded (compensating with it gives SPH_ERROR_NOT_LOADED). */
sph_status sph_calibration_load(sph_calibration* cal, const void* blob, size_t size);
sph_status sph_calibration_load_f(sph_calibration_f* cal, const void* blob, size_t size);

/** The compensated point of one reading. */
sph_status sph_compensate(const sph_calibration* cal, const sph_reading* reading, sph_point* point);
/** points[i] of readings[i] for i < count; SPH_ERROR_READING when a reading was not finite (its
 * point is NaN, the others are compensated). */
sph_status sph_compensate_batch(const sph_calibration* cal, const sph_reading* readings, size_t count,
                                sph_point* points);

/** The same in float. */
sph_status sph_compensate_f(const sph_calibration_f* cal, const sph_reading_f* reading, sph_point_f* point);
sph_status sph_compensate_batch_f(const sph_calibration_f* cal, const sph_reading_f* readings, size_t count,
                                  sph_point_f* points);

/** A short English text of a status ("the blob's CRC-32 does not match", ...). */
const char* sph_status_text(sph_status status);

#ifdef __cplusplus
}
#endif

#endif /* SPH_C_COMPENSATION_H_ */
