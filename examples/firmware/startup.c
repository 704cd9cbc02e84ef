/* Start-up for the Cortex-M7 of QEMU's mps2-an500: the vector table, the reset handler and the
 * fault handlers. Linked with -nostartfiles and cortex-m7.ld, which provides the symbols below.
 *
 * Reset: enable the FPU, copy .data from flash to RAM, zero .bss, run the constructors
 * (.preinit_array, .init_array), call main and end the program with board_exit(main's value).
 * Faults and unexpected interrupts print one line through semihosting and exit with failure. */
#include <stdint.h>

#include "board.h"

int main(void);

void Reset_Handler(void) __attribute__((noreturn));
void board_fault_report(const uint32_t *frame) __attribute__((noreturn));

/* From cortex-m7.ld. */
extern char __stack_top[];
extern uint32_t __data_load[], __data_start[], __data_end[];
extern uint32_t __bss_start[], __bss_end[];
typedef void (*init_function)(void);
extern const init_function __preinit_array_start[], __preinit_array_end[];
extern const init_function __init_array_start[], __init_array_end[];

/* System control registers. */
#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SCB_CFSR (*(volatile uint32_t *)0xE000ED28u)
#define SCB_HFSR (*(volatile uint32_t *)0xE000ED2Cu)
#define SCB_MMFAR (*(volatile uint32_t *)0xE000ED34u)
#define SCB_BFAR (*(volatile uint32_t *)0xE000ED38u)
#define CPACR_CP10_CP11_FULL (0xFu << 20) /* CP10 and CP11: full access (0b11 each) */

/* The handlers for every exception but reset share one entry. */
static void fault_entry(void) __attribute__((naked, noreturn));

/* The vector table: the initial stack pointer, then the 15 system exceptions and the board's
 * 32 interrupts (the NVIC of QEMU's mps2-an500 has 32). Placed at address 0 by the linker
 * script (VTOR resets to 0). 48 words, so the table is also within the 256-byte alignment a
 * relocated table of this size would need. */
struct vector_table {
  void *initial_stack;
  init_function exceptions[15]; /* exception numbers 1 to 15 */
  init_function interrupts[32]; /* exception numbers 16 to 47 */
};

__attribute__((section(".vectors"), used))
const struct vector_table vector_table = {
  __stack_top,
  {
    Reset_Handler,
    fault_entry, /*  2 NMI */
    fault_entry, /*  3 HardFault */
    fault_entry, /*  4 MemManage */
    fault_entry, /*  5 BusFault */
    fault_entry, /*  6 UsageFault */
    0, 0, 0, 0,  /*  7-10 reserved */
    fault_entry, /* 11 SVCall */
    fault_entry, /* 12 DebugMonitor */
    0,           /* 13 reserved */
    fault_entry, /* 14 PendSV */
    fault_entry, /* 15 SysTick */
  },
  {
    fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry,
    fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry,
    fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry,
    fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry, fault_entry,
    fault_entry, fault_entry, fault_entry, fault_entry,
  },
};

/* Everything after the FPU is on. Kept out of line so that no floating-point instruction the
 * compiler might choose (it may also turn the loops into memcpy and memset calls) can run
 * before CPACR allows it. */
static void start_c(void) __attribute__((noinline, noreturn));

static void start_c(void)
{
  const uint32_t *from = __data_load;
  uint32_t *to = __data_start;

  while (to < __data_end) {
    *to++ = *from++;
  }
  for (to = __bss_start; to < __bss_end; to++) {
    *to = 0u;
  }
  for (const init_function *f = __preinit_array_start; f < __preinit_array_end; f++) {
    (*f)();
  }
  for (const init_function *f = __init_array_start; f < __init_array_end; f++) {
    (*f)();
  }
  board_exit(main());
}

void Reset_Handler(void)
{
  /* The FPU is off at reset: any floating-point instruction would raise a UsageFault (NOCP).
   * Grant full access to CP10 and CP11, then DSB so the write has completed and ISB so that
   * following instructions are fetched with the new setting. */
  SCB_CPACR |= CPACR_CP10_CP11_FULL;
  __asm__ volatile("dsb\n\tisb" ::: "memory");
  start_c();
}

/* Finds the stacked exception frame (main or process stack, from bit 2 of EXC_RETURN in LR)
 * and passes it to board_fault_report. */
static void fault_entry(void)
{
  __asm__ volatile(
      "tst lr, #4\n\t"
      "ite eq\n\t"
      "mrseq r0, msp\n\t"
      "mrsne r0, psp\n\t"
      "b board_fault_report\n\t");
}

static size_t append_text(char *line, size_t at, const char *text)
{
  while (*text != '\0') {
    line[at++] = *text++;
  }
  return at;
}

static size_t append_hex(char *line, size_t at, uint32_t value)
{
  static const char digits[] = "0123456789abcdef";

  line[at++] = '0';
  line[at++] = 'x';
  for (int shift = 28; shift >= 0; shift -= 4) {
    line[at++] = digits[(value >> shift) & 0xFu];
  }
  return at;
}

static size_t append_decimal(char *line, size_t at, uint32_t value)
{
  char reversed[10];
  size_t count = 0;

  do {
    reversed[count++] = (char)('0' + value % 10u);
    value /= 10u;
  } while (value != 0u);
  while (count > 0u) {
    line[at++] = reversed[--count];
  }
  return at;
}

/* "fault: HardFault (exception 3) pc 0x... lr 0x... cfsr 0x... hfsr 0x... mmfar 0x...
 * bfar 0x...": pc is the instruction that faulted (or was interrupted), lr the stacked LR;
 * CFSR and HFSR say why (the ARMv7-M Architecture Reference Manual decodes them). */
void board_fault_report(const uint32_t *frame)
{
  static const char *const names[16] = {
    "Thread", "Reset", "NMI", "HardFault", "MemManage", "BusFault", "UsageFault", "Reserved",
    "Reserved", "Reserved", "Reserved", "SVCall", "DebugMonitor", "Reserved", "PendSV",
    "SysTick",
  };
  char line[200];
  size_t at = 0;
  uint32_t exception;

  __asm__ volatile("mrs %0, ipsr" : "=r"(exception));
  exception &= 0x1FFu;

  at = append_text(line, at, "fault: ");
  if (exception < 16u) {
    at = append_text(line, at, names[exception]);
  } else {
    at = append_text(line, at, "unexpected interrupt IRQ");
    at = append_decimal(line, at, exception - 16u);
  }
  at = append_text(line, at, " (exception ");
  at = append_decimal(line, at, exception);
  at = append_text(line, at, ") pc ");
  at = append_hex(line, at, frame[6]);
  at = append_text(line, at, " lr ");
  at = append_hex(line, at, frame[5]);
  at = append_text(line, at, " cfsr ");
  at = append_hex(line, at, SCB_CFSR);
  at = append_text(line, at, " hfsr ");
  at = append_hex(line, at, SCB_HFSR);
  at = append_text(line, at, " mmfar ");
  at = append_hex(line, at, SCB_MMFAR);
  at = append_text(line, at, " bfar ");
  at = append_hex(line, at, SCB_BFAR);
  line[at++] = '\n';
  board_write(line, at);
  board_exit(1);
}
