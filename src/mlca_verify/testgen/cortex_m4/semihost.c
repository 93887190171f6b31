/* Arm semihosting: text out on the host's standard output, and the exit with a status (QEMU's exit code). */
#include <stdint.h>

static uintptr_t semihost(uintptr_t op, const void *arg)
{
    register uintptr_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void target_write(const char *text)
{
    (void)semihost(0x04u, text); /* SYS_WRITE0: a NUL-terminated string */
}

void target_exit(int status)
{
    const uintptr_t block[2] = {0x20026u, (uintptr_t)(intptr_t)status}; /* ADP_Stopped_ApplicationExit */
    for (;;) {
        (void)semihost(0x20u, block); /* SYS_EXIT_EXTENDED */
    }
}
