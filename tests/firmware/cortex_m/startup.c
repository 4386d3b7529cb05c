/* Start-up of the bare-metal test program on qemu's mps2-an500 (Cortex-M7): the vector table, the
 * copy of .data and the zeroing of .bss, the FPU enabled, the stack painted for the high-water
 * mark; then main() and its status through semihosting. */
#include <stdint.h>

#include "semihosting.h"

extern uint32_t __data_load__, __data_start__, __data_end__, __bss_start__, __bss_end__;
extern uint32_t __stack_limit__, __stack_top__;
int main(void);

void Reset_Handler(void);
void Fault_Handler(void);

__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {(void (*)(void))(&__stack_top__),
                                                                                     Reset_Handler,
                                                                                     Fault_Handler,
                                                                                     Fault_Handler,
                                                                                     Fault_Handler,
                                                                                     Fault_Handler,
                                                                                     Fault_Handler,
                                                                                     0,
                                                                                     0,
                                                                                     0,
                                                                                     0,
                                                                                     Fault_Handler,
                                                                                     Fault_Handler,
                                                                                     0,
                                                                                     Fault_Handler,
                                                                                     Fault_Handler};

void Fault_Handler(void) {
  sh_write0("fault\n");
  sh_exit(3);
}

__attribute__((naked)) void Reset_Handler(void) {
  /* Paint the stack below the current frame with a pattern (a naked function: no frame of its own),
   * so that the high-water mark can be found after the run. */
  __asm volatile(
      "ldr r0, =__stack_limit__\n"
      "mov r1, sp\n"
      "ldr r2, =0x5AA5C33C\n"
      "1: cmp r0, r1\n"
      "bhs 2f\n"
      "str r2, [r0], #4\n"
      "b 1b\n"
      "2: b sph_start\n");
}

void sph_start(void) {
  uint32_t* src = &__data_load__;
  for (uint32_t* dst = &__data_start__; dst < &__data_end__;) *dst++ = *src++;
  for (uint32_t* dst = &__bss_start__; dst < &__bss_end__;) *dst++ = 0;
  /* CPACR: full access to CP10 and CP11 (the FPU). */
  *(volatile uint32_t*)0xE000ED88 |= (0xFu << 20);
  __asm volatile("dsb\nisb");
  sh_exit(main());
}

/* The bytes of the stack used so far: from its limit up to the first word not holding the pattern. */
uint32_t stack_used_bytes(void) {
  const uint32_t* p = &__stack_limit__;
  while (p < &__stack_top__ && *p == 0x5AA5C33Cu) ++p;
  return (uint32_t)((const char*)&__stack_top__ - (const char*)p);
}
