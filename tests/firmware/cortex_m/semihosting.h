/* Semihosting calls (ARM's "bkpt 0xab" interface), enough to print and to exit with a status. */
#ifndef SPH_FIRMWARE_SEMIHOSTING_H_
#define SPH_FIRMWARE_SEMIHOSTING_H_

#include <stdint.h>

static inline uint32_t sh_call(uint32_t op, const void* arg) {
  register uint32_t r0 __asm("r0") = op;
  register const void* r1 __asm("r1") = arg;
  __asm volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

/* Writes a NUL-terminated string to the host's console (SYS_WRITE0). */
static inline void sh_write0(const char* s) { sh_call(0x04, s); }

/* Ends the program with `status` (SYS_EXIT_EXTENDED, ADP_Stopped_ApplicationExit): qemu exits with it. */
static inline void sh_exit(int status) {
  const uint32_t block[2] = {0x20026u, (uint32_t)status};
  sh_call(0x20, block);
  for (;;) {
  }
}

uint32_t stack_used_bytes(void);

#endif /* SPH_FIRMWARE_SEMIHOSTING_H_ */
