/* board.h for QEMU's mps2-an500 (Cortex-M7): console and exit through ARM semihosting, the
 * instruction counter on the CMSDK APB TIMER0.
 *
 * Semihosting on M-profile: the operation number goes in r0, its argument (a value or the
 * address of a parameter block of 32-bit words) in r1, then "bkpt 0xab"; the result comes back
 * in r0. QEMU implements it with -semihosting-config enable=on,target=native. */
#include "board.h"

/* Semihosting operations (ARM "Semihosting for AArch32 and AArch64", version 2). */
#define SYS_OPEN 0x01u
#define SYS_WRITEC 0x03u
#define SYS_WRITE 0x05u
#define SYS_EXIT 0x18u

/* SYS_EXIT reasons. On AArch32 the reason is r1 itself, with no room for an exit code: QEMU
 * exits with status 0 for ApplicationExit and 1 for every other reason. */
#define ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN 0x20023u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

/* SYS_OPEN mode 4 is "w" in the fopen() numbering the operation uses. */
#define OPEN_MODE_WRITE 4u

static uint32_t semihost(uint32_t operation, const void *argument)
{
  register uint32_t r0 __asm__("r0") = operation;
  register const void *r1 __asm__("r1") = argument;
  /* "memory": the host reads the parameter block and what it points to. */
  __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

/* The console handle from SYS_OPEN(":tt"), opened on first use. Both variables live in .bss,
 * so they read as "not opened yet" even for a fault report before .data has been copied. */
static uint32_t console_handle;
static int console_state; /* 0: not tried, 1: open, -1: SYS_OPEN failed, use SYS_WRITEC */

static void console_open(void)
{
  static const char name[] = ":tt"; /* the semihosting name of the host's console */
  uint32_t block[3];
  uint32_t handle;

  block[0] = (uint32_t)(uintptr_t)name;
  block[1] = OPEN_MODE_WRITE;
  block[2] = (uint32_t)(sizeof name - 1u);
  handle = semihost(SYS_OPEN, block);
  if (handle == 0xFFFFFFFFu) {
    console_state = -1;
  } else {
    console_handle = handle;
    console_state = 1;
  }
}

/* SYS_WRITE with a length, so no terminator is needed and a single trap carries the whole
 * buffer. (SYS_WRITE0 needs a NUL-terminated string and SYS_WRITEC traps once per byte; the
 * latter is kept as the fallback should the host refuse to open ":tt".) The handle must come
 * from SYS_OPEN: QEMU has no pre-opened standard handles for ARM semihosting, and a SYS_WRITE
 * to handle 1 without it writes nothing. */
void board_write(const char *text, size_t length)
{
  if (console_state == 0) {
    console_open();
  }
  if (console_state > 0) {
    while (length > 0u) {
      uint32_t block[3];
      uint32_t unwritten;
      uint32_t chunk = length > 0x7FFFFFFFu ? 0x7FFFFFFFu : (uint32_t)length;

      block[0] = console_handle;
      block[1] = (uint32_t)(uintptr_t)text;
      block[2] = chunk;
      unwritten = semihost(SYS_WRITE, block); /* returns the number of bytes NOT written */
      if (unwritten >= chunk) {
        return; /* nothing written: the console is gone, give up rather than spin */
      }
      text += chunk - unwritten;
      length -= chunk - unwritten;
    }
  } else {
    for (size_t i = 0; i < length; i++) {
      semihost(SYS_WRITEC, &text[i]);
    }
  }
}

void board_exit(int status)
{
  uintptr_t reason = status == 0 ? ADP_STOPPED_APPLICATION_EXIT
                                 : ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN;

  semihost(SYS_EXIT, (const void *)reason);
  /* Only reached if the host ignored the request: stop here. */
  for (;;) {
    __asm__ volatile("bkpt 0x00");
  }
}

/* The counter: CMSDK APB timer 0, a 32-bit down-counter clocked by PCLK (25 MHz on mps2-an500,
 * in QEMU too). It runs free from 0xFFFFFFFF with RELOAD 0xFFFFFFFF and its interrupt disabled,
 * so it wraps every 2^32 ticks and nothing but the program's own instructions executes while it
 * counts. Each read adds the ticks elapsed since the previous read, modulo 2^32, to a 64-bit
 * total: exact across any number of wraps as long as reads are less than 2^32 ticks apart.
 *
 * Precision under -icount shift=0 (1 ns of virtual time per instruction, 40 instructions a
 * tick), measured with loops of known length: the timer starts at the enabling write and each
 * reading is truncated to a whole tick. Built at -O2, start, N instructions, read gives
 * floor((N + 6) / 40) ticks (6: the return from start, the call to read and the instructions
 * in it before the timer is sampled), so ticks * 40 is within -34 and +6 of N; between two
 * reads the difference is within one tick (+-40 instructions). 2e6, 2e7 and 1e10 instructions
 * (the last is 10 s of virtual time) read as 50000, 500000 and 250000001 ticks; a wrap of the
 * 32-bit timer between two reads changes nothing. */
#define TIMER0_BASE 0x40000000u
#define TIMER_CTRL (*(volatile uint32_t *)(TIMER0_BASE + 0x00u))
#define TIMER_VALUE (*(volatile uint32_t *)(TIMER0_BASE + 0x04u))
#define TIMER_RELOAD (*(volatile uint32_t *)(TIMER0_BASE + 0x08u))
#define TIMER_INTCLEAR (*(volatile uint32_t *)(TIMER0_BASE + 0x0Cu))
#define TIMER_CTRL_ENABLE 0x1u

static uint32_t counter_last; /* raw VALUE at the previous read */
static uint64_t counter_total; /* ticks up to that read */

void board_counter_start(void)
{
  TIMER_CTRL = 0u; /* stopped, internal clock, interrupt disabled */
  TIMER_INTCLEAR = 1u;
  TIMER_RELOAD = 0xFFFFFFFFu;
  TIMER_VALUE = 0xFFFFFFFFu;
  counter_last = 0xFFFFFFFFu;
  counter_total = 0u;
  TIMER_CTRL = TIMER_CTRL_ENABLE;
}

uint64_t board_counter_read(void)
{
  uint32_t now = TIMER_VALUE;

  counter_total += (uint32_t)(counter_last - now); /* down-counter: elapsed = before - now */
  counter_last = now;
  return counter_total;
}
