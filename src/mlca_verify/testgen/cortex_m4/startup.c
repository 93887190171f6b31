/* Start-up for the MPS2 AN386 board (Cortex-M4) as QEMU emulates it: the vector table, a reset handler that
 * lays out .data and .bss and calls main, and the exit through Arm semihosting with main's status. */
#include <stdint.h>

extern int main(void);
extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end, __stack_top;

void target_exit(int status);

static void reset(void)
{
    const uint32_t *from = &__data_load;
    uint32_t *to;
    for (to = &__data_start; to < &__data_end; ++to) {
        *to = *from++;
    }
    for (to = &__bss_start; to < &__bss_end; ++to) {
        *to = 0u;
    }
    target_exit(main());
}

static void halt(void)
{
    target_exit(100);
}

typedef void (*handler_t)(void);

/* The initial stack pointer, then the reset handler and the fault and system handlers (the rest unused). */
__attribute__((section(".vectors"), used)) static const struct {
    uint32_t *stack;
    handler_t handlers[15];
} vectors = {
    &__stack_top,
    {reset, halt, halt, halt, halt, halt, 0, 0, 0, 0, halt, halt, 0, halt, halt},
};
