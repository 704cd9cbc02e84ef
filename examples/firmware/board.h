/* The board interface of the firmware example: text output, exit status and an instruction
 * counter. board_semihost.c implements it for QEMU's mps2-an500 (Cortex-M7) through ARM
 * semihosting; a real board would supply its own UART, reset and timer behind the same calls.
 *
 * Semihosting traps into the debugger or emulator: under QEMU it needs
 * -semihosting-config enable=on,target=native, and without a host every call faults. */
#ifndef PGEM_FIRMWARE_BOARD_H
#define PGEM_FIRMWARE_BOARD_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Writes length bytes of text to the host's console (under QEMU: QEMU's standard output).
 * No formatting, no buffering; the bytes may include newlines. */
void board_write(const char *text, size_t length);

/* Ends the program: status 0 makes QEMU exit with status 0, anything else with status 1. */
void board_exit(int status) __attribute__((noreturn));

/* The counter: board_counter_start() sets it to zero, board_counter_read() returns the ticks
 * since then. It is the CMSDK APB TIMER0 (at 0x40000000), clocked at 25 MHz (40 ns a tick),
 * extended to 64 bits in software: reads must be less than 2^32 ticks (171.8 s) apart.
 * Not for use from interrupt handlers (the extension is unguarded state).
 *
 * With QEMU's -icount shift=0 every guest instruction advances virtual time by exactly 1 ns,
 * so instructions = ticks * BOARD_COUNTER_NS_PER_TICK, to within one tick (40 instructions);
 * board_semihost.c gives the measured precision. These are executed instructions, not the
 * cycles a real Cortex-M7 would take. Without -icount QEMU's virtual time follows the host's
 * clock, and the counter measures emulation speed, which says nothing about the firmware. */
#define BOARD_COUNTER_HZ 25000000u
#define BOARD_COUNTER_NS_PER_TICK 40u

void board_counter_start(void);
uint64_t board_counter_read(void);

#ifdef __cplusplus
}
#endif

#endif
