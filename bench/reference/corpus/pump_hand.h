/* Hand-written reference for the corpus machine tests/machines/pump_debounce_1khz.toml (a debounced
 * over-temperature trip), over the generated header's input and param types, with its own context and outputs.
 * bench/bench_corpus_code.py measures pumpdebounce_step against pump_hand_step. */
#ifndef PUMP_HAND_H
#define PUMP_HAND_H

#include "pumpdebounce_fsm.h"

typedef struct {
    bool tripped;
    uint16_t count; /* hot samples in a row, saturating at 10,000 */
} pump_hand_t;

typedef struct {
    uint8_t pump_on; /* the pump relay */
} pump_hand_out_t;

void pump_hand_init(pump_hand_t *h);
void pump_hand_step(pump_hand_t *h, const pumpdebounce_inputs_t *in, const pumpdebounce_params_t *p,
    pump_hand_out_t *o);

/* For the benchmark's driver only: whether the two agree on the mode, the count and the output. */
int pump_hand_agrees(const pump_hand_t *h, const pump_hand_out_t *o, const pumpdebounce_ctx_t *c,
    const pumpdebounce_outputs_t *go);

#endif /* PUMP_HAND_H */
