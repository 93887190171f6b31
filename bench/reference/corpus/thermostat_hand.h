/* Hand-written reference for the corpus machine tests/machines/thermostat_1hz.toml (a thermostat with hysteresis,
 * minimum on and off times and a sensor fault mode), over the generated header's input and param types, with its
 * own context and outputs. bench/bench_corpus_code.py measures thermostat_step against thermostat_hand_step. */
#ifndef THERMOSTAT_HAND_H
#define THERMOSTAT_HAND_H

#include "thermostat_fsm.h"

typedef struct {
    uint8_t state; /* TH_OFF, TH_HEATING or TH_FAULT */
    uint16_t dwell; /* steps in the current state, saturating at 3,600 */
} thermostat_hand_t;

typedef struct {
    uint8_t boiler; /* the boiler relay */
} thermostat_hand_out_t;

void thermostat_hand_init(thermostat_hand_t *h);
void thermostat_hand_step(thermostat_hand_t *h, const thermostat_inputs_t *in, const thermostat_params_t *p,
    thermostat_hand_out_t *o);

/* For the benchmark's driver only: whether the two agree on the mode, the dwell time and the output. */
int thermostat_hand_agrees(const thermostat_hand_t *h, const thermostat_hand_out_t *o, const thermostat_ctx_t *c,
    const thermostat_outputs_t *go);

#endif /* THERMOSTAT_HAND_H */
