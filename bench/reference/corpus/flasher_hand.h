/* Hand-written reference for the corpus machine tests/machines/flasher_100hz.toml (a turn signal and hazard
 * flasher that flashes twice as fast when a bulb is out), over the generated header's input and param types, with
 * its own context and outputs. bench/bench_corpus_code.py measures flasher_step against flasher_hand_step. */
#ifndef FLASHER_HAND_H
#define FLASHER_HAND_H

#include "flasher_fsm.h"

typedef struct {
    uint8_t state; /* FL_OFF, FL_LEFT, FL_RIGHT or FL_HAZARD */
    uint16_t phase; /* steps into the flash period */
} flasher_hand_t;

typedef struct {
    bool lamp_l; /* the left lamps are lit */
    bool lamp_r; /* the right lamps are lit */
} flasher_hand_out_t;

void flasher_hand_init(flasher_hand_t *h);
void flasher_hand_step(flasher_hand_t *h, const flasher_inputs_t *in, const flasher_params_t *p,
    flasher_hand_out_t *o);

/* For the benchmark's driver only: whether the two agree on the mode, the phase and the outputs. */
int flasher_hand_agrees(const flasher_hand_t *h, const flasher_hand_out_t *o, const flasher_ctx_t *c,
    const flasher_outputs_t *go);

#endif /* FLASHER_HAND_H */
