/* Hand-written reference for tests/machines/pump_debounce_1khz.toml, as an embedded C programmer would write
 * it: a flag and a 16-bit counter, the hot test written once, an 8-bit relay output. */
#include "pump_hand.h"

#define TEMP_MIN (-40.0)
#define TEMP_MAX 150.0
#define COUNT_MAX 10000u

void pump_hand_init(pump_hand_t *h)
{
    h->tripped = false;
    h->count = 0u;
}

void pump_hand_step(pump_hand_t *h, const pumpdebounce_inputs_t *in, const pumpdebounce_params_t *p,
    pump_hand_out_t *o)
{
    /* an invalid sample (out of range or NaN) counts as hot */
    const bool valid = (TEMP_MIN <= in->temp) && (in->temp <= TEMP_MAX);
    const bool hot = !valid || (in->temp > p->LIMIT);
    if (h->tripped) {
        if (in->reset && !hot) {
            h->tripped = false;
        }
    } else if (hot && ((int32_t)h->count >= (p->DEBOUNCE - 1))) {
        h->tripped = true;
    } else {
        /* running, not tripping */
    }
    if (!hot) {
        h->count = 0u;
    } else if (h->count < COUNT_MAX) {
        h->count += 1u;
    } else {
        /* saturated */
    }
    o->pump_on = h->tripped ? 0u : 1u;
}

int pump_hand_agrees(const pump_hand_t *h, const pump_hand_out_t *o, const pumpdebounce_ctx_t *c,
    const pumpdebounce_outputs_t *go)
{
    const pumpdebounce_state_t mode = h->tripped ? PUMPDEBOUNCE_TRIPPED : PUMPDEBOUNCE_RUNNING;
    return (c->mode == mode) && (c->count == (int32_t)h->count) && (go->pump_on == (int64_t)o->pump_on);
}
