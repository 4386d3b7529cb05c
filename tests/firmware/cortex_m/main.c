/* The bare-metal test program: loads the calibration blob (a generated C source of constants)
 * through sph/c/compensation.h, compensates the readings (a generated C source) in double and in
 * float, and prints every point as the bits of its coordinates for the host to compare
 * (tests/firmware/firmware_host.cpp), with what the run cost: SysTick ticks and the stack's
 * high-water mark. C99, no heap, no printf. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "semihosting.h"
#include "sph/c/compensation.h"

extern const unsigned char sph_calibration_blob[];
extern const size_t sph_calibration_blob_size;
extern const sph_reading sph_test_readings[];
extern const size_t sph_test_readings_count;

#define MAX_READINGS 4096

static sph_calibration cal;
static sph_calibration_f cal_f;
static sph_point points[MAX_READINGS];
static sph_point single[MAX_READINGS];
static sph_reading_f readings_f[MAX_READINGS];
static sph_point_f points_f[MAX_READINGS];
static unsigned char damaged[8192];

#define SYST_CSR (*(volatile uint32_t*)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t*)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t*)0xE000E018u)

static void put_hex(char* out, uint64_t v, int digits) {
  for (int i = digits - 1; i >= 0; --i) {
    out[i] = "0123456789abcdef"[v & 0xF];
    v >>= 4;
  }
}

static void print_u32(const char* tag, uint32_t v) {
  char line[32];
  size_t n = strlen(tag);
  memcpy(line, tag, n);
  line[n++] = ' ';
  char digits[11];
  int k = 0;
  do {
    digits[k++] = (char)('0' + v % 10);
    v /= 10;
  } while (v != 0);
  while (k > 0) line[n++] = digits[--k];
  line[n++] = '\n';
  line[n] = '\0';
  sh_write0(line);
}

static void print_point(char tag, uint32_t i, const double* xyz) {
  char line[80];
  line[0] = tag;
  line[1] = ' ';
  put_hex(line + 2, i, 4);
  for (int c = 0; c < 3; ++c) {
    uint64_t bits;
    memcpy(&bits, &xyz[c], sizeof bits);
    line[6 + 17 * c] = ' ';
    put_hex(line + 7 + 17 * c, bits, 16);
  }
  line[57] = '\n';
  line[58] = '\0';
  sh_write0(line);
}

static void print_point_f(uint32_t i, const sph_point_f* p) {
  char line[48];
  const float xyz[3] = {p->x_mm, p->y_mm, p->z_mm};
  line[0] = 'F';
  line[1] = ' ';
  put_hex(line + 2, i, 4);
  for (int c = 0; c < 3; ++c) {
    uint32_t bits;
    memcpy(&bits, &xyz[c], sizeof bits);
    line[6 + 9 * c] = ' ';
    put_hex(line + 7 + 9 * c, bits, 8);
  }
  line[33] = '\n';
  line[34] = '\0';
  sh_write0(line);
}

static uint32_t ticks_since(uint32_t start) { return (start - SYST_CVR) & 0xFFFFFFu; }

static int fail(const char* what, sph_status s) {
  sh_write0("error: ");
  sh_write0(what);
  sh_write0(": ");
  sh_write0(sph_status_text(s));
  sh_write0("\n");
  return 1;
}

int main(void) {
  const size_t n = sph_test_readings_count;
  if (n > MAX_READINGS || sph_calibration_blob_size > sizeof damaged) return fail("fixture too large", SPH_OK);
#ifdef SPH_FIRMWARE_TRY_HEAP
  /* Referencing the heap must not link: the test of the link's refusal builds this. */
  extern void* malloc(size_t);
  if (malloc(1) == 0) return 1;
#endif
  sph_status s = sph_calibration_load(&cal, sph_calibration_blob, sph_calibration_blob_size);
  if (s != SPH_OK) return fail("loading the calibration", s);
  s = sph_calibration_load_f(&cal_f, sph_calibration_blob, sph_calibration_blob_size);
  if (s != SPH_OK) return fail("loading the calibration in float", s);

  /* A blob damaged in one byte is refused, and the calibration it was loaded into compensates nothing. */
  static sph_calibration refused;
  memcpy(damaged, sph_calibration_blob, sph_calibration_blob_size);
  damaged[100] ^= 0x01;
  s = sph_calibration_load(&refused, damaged, sph_calibration_blob_size);
  print_u32("DAMAGED", (uint32_t)s);
  sph_point p;
  print_u32("UNLOADED", (uint32_t)sph_compensate(&refused, &sph_test_readings[0], &p));

  for (size_t i = 0; i < n; ++i) {
    readings_f[i].theta_deg = (float)sph_test_readings[i].theta_deg;
    readings_f[i].phi_deg = (float)sph_test_readings[i].phi_deg;
    readings_f[i].r_mm = (float)sph_test_readings[i].r_mm;
  }

  SYST_RVR = 0xFFFFFFu;
  SYST_CVR = 0;
  SYST_CSR = 5; /* enabled, processor clock, no interrupt */
  uint32_t t0 = SYST_CVR;
  s = sph_compensate_batch(&cal, sph_test_readings, n, points);
  const uint32_t ticks_batch = ticks_since(t0);
  if (s != SPH_OK) return fail("compensating", s);
  t0 = SYST_CVR;
  s = sph_compensate_batch_f(&cal_f, readings_f, n, points_f);
  const uint32_t ticks_batch_f = ticks_since(t0);
  if (s != SPH_OK) return fail("compensating in float", s);
  t0 = SYST_CVR;
  for (size_t i = 0; i < n; ++i) s |= sph_compensate(&cal, &sph_test_readings[i], &single[i]);
  const uint32_t ticks_single = ticks_since(t0);
  if (s != SPH_OK) return fail("compensating one reading", s);
  t0 = SYST_CVR;
  const uint32_t ticks_empty = ticks_since(t0);
  /* What a tick is in instructions: a loop of 2 instructions (subs, bne) run 1,000,000 times. */
  uint32_t count = 1000000u;
  t0 = SYST_CVR;
  __asm volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(count) : : "cc");
  const uint32_t ticks_loop = ticks_since(t0);

  for (size_t i = 0; i < n; ++i) {
    print_point('D', (uint32_t)i, &points[i].x_mm);
    if (memcmp(&points[i], &single[i], sizeof points[i]) != 0) print_point('S', (uint32_t)i, &single[i].x_mm);
    print_point_f((uint32_t)i, &points_f[i]);
  }
  print_u32("READINGS", (uint32_t)n);
  print_u32("TICKS_BATCH", ticks_batch);
  print_u32("TICKS_BATCH_F", ticks_batch_f);
  print_u32("TICKS_SINGLE", ticks_single);
  print_u32("TICKS_EMPTY", ticks_empty);
  print_u32("TICKS_LOOP_2000000", ticks_loop);
  print_u32("STACK_BYTES", stack_used_bytes());
  sh_write0("END\n");
  return 0;
}
