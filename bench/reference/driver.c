/* Runs STEPS steps of the function STEP_FN over a fixed pseudo-random input sequence (a 32-bit LCG with a fixed
 * seed), so that callgrind counts the same work for every candidate. */
#include <stdio.h>
#include "mlca_fsm.h"

mlca_state_t STEP_FN(mlca_state_t s, mlca_inputs_t in);

int main(void)
{
    unsigned long k;
    unsigned int seed = 12345u;
    unsigned long visits[4] = {0u, 0u, 0u, 0u};
    mlca_state_t s = MLCA_INITIAL;
    for (k = 0u; k < STEPS; ++k) {
        mlca_inputs_t in;
        seed = seed * 1103515245u + 12345u;
        in.N = ((seed >> 16) & 7u) != 0u; /* a lane change is needed 7 steps in 8 */
        in.W = ((seed >> 19) & 1u) != 0u;
        in.L = ((seed >> 20) & 3u) == 0u;
        in.R = ((seed >> 22) & 3u) == 0u;
        s = STEP_FN(s, in);
        visits[(unsigned)s & 3u] += 1u;
    }
    printf("%lu %lu %lu %lu\n", visits[0], visits[1], visits[2], visits[3]);
    return 0;
}
