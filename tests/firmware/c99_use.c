/* sph/c/compensation.h used from C99 (built with -std=c99 -pedantic): loads a blob, compensates one
 * reading and a batch of one, and returns the point. */
#include <stddef.h>
#include <string.h>

#include "sph/c/compensation.h"

int sph_c99_compensate(const unsigned char* blob, size_t size, double theta_deg, double phi_deg, double r_mm,
                       double out_mm[3]) {
  static sph_calibration cal;
  sph_reading reading;
  sph_point one, batch[1];
  sph_status s = sph_calibration_load(&cal, blob, size);
  if (s != SPH_OK) return (int)s;
  reading.theta_deg = theta_deg;
  reading.phi_deg = phi_deg;
  reading.r_mm = r_mm;
  s = sph_compensate(&cal, &reading, &one);
  if (s != SPH_OK) return (int)s;
  s = sph_compensate_batch(&cal, &reading, 1, batch);
  if (s != SPH_OK) return (int)s;
  if (memcmp(&one, &batch[0], sizeof one) != 0) return -1;
  out_mm[0] = one.x_mm;
  out_mm[1] = one.y_mm;
  out_mm[2] = one.z_mm;
  return 0;
}
