/* The benchmarks' fixed pseudo-random sequence: splitmix64 from the seed SEED (a macro the build defines), so
 * that every candidate of a run sees the same inputs. Included by the lockstep drivers of bench/. */
#ifndef SPLITMIX_H
#define SPLITMIX_H

#include <stdint.h>

static uint64_t rng = SEED;

static uint64_t next(void)
{
    uint64_t z = (rng += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

static int one_in(unsigned n) { return (next() % n) == 0u; }

#endif /* SPLITMIX_H */
