/* Hand-written reference for tests/machines/flasher_100hz.toml, as an embedded C programmer would write it: a
 * switch over an 8-bit state, a 16-bit phase, the bulb check made once a step, two boolean lamp outputs. */
#include "flasher_hand.h"

#define FL_OFF 0u
#define FL_LEFT 1u
#define FL_RIGHT 2u
#define FL_HAZARD 3u
#define CURRENT_MIN 0.0
#define CURRENT_MAX 10.0

void flasher_hand_init(flasher_hand_t *h)
{
    h->state = FL_OFF;
    h->phase = 0u;
}

static uint8_t next_state(uint8_t state, const flasher_inputs_t *in)
{
    uint8_t next = state;
    switch (state) {
    case FL_OFF:
        if (in->hazard) {
            next = FL_HAZARD;
        } else if (in->stalk_left) {
            next = FL_LEFT;
        } else if (in->stalk_right) {
            next = FL_RIGHT;
        } else {
            /* stays off */
        }
        break;
    case FL_LEFT:
        if (in->hazard) {
            next = FL_HAZARD;
        } else if (in->stalk_right) {
            next = FL_RIGHT;
        } else if (!in->stalk_left) {
            next = FL_OFF;
        } else {
            /* keeps flashing left */
        }
        break;
    case FL_RIGHT:
        if (in->hazard) {
            next = FL_HAZARD;
        } else if (in->stalk_left) {
            next = FL_LEFT;
        } else if (!in->stalk_right) {
            next = FL_OFF;
        } else {
            /* keeps flashing right */
        }
        break;
    default:
        if (!in->hazard) {
            next = FL_OFF;
        }
        break;
    }
    return next;
}

void flasher_hand_step(flasher_hand_t *h, const flasher_inputs_t *in, const flasher_params_t *p,
    flasher_hand_out_t *o)
{
    const uint8_t next = next_state(h->state, in);
    if (next != h->state) {
        h->state = next;
        h->phase = 0u;
    } else {
        /* a lit lamp drawing too little current, or an invalid reading, means a bulb is out: count twice as fast */
        const double amps = in->lamp_current;
        const bool valid = (CURRENT_MIN <= amps) && (amps <= CURRENT_MAX);
        const bool bulb_out = !valid || (((int32_t)h->phase < p->ON_STEPS) && (amps < p->I_MIN));
        const int32_t advanced = (int32_t)h->phase + (bulb_out ? 2 : 1);
        h->phase = (advanced >= (p->ON_STEPS + p->OFF_STEPS)) ? 0u : (uint16_t)advanced;
    }
    {
        const bool lit = (int32_t)h->phase < p->ON_STEPS;
        o->lamp_l = lit && ((next == FL_LEFT) || (next == FL_HAZARD));
        o->lamp_r = lit && ((next == FL_RIGHT) || (next == FL_HAZARD));
    }
}

int flasher_hand_agrees(const flasher_hand_t *h, const flasher_hand_out_t *o, const flasher_ctx_t *c,
    const flasher_outputs_t *go)
{
    static const flasher_state_t modes[4] = {FLASHER_OFF, FLASHER_LEFT, FLASHER_RIGHT, FLASHER_HAZARD};
    return (h->state < 4u) && (c->mode == modes[h->state]) && (c->phase == (int32_t)h->phase)
        && (go->lamp_l == o->lamp_l) && (go->lamp_r == o->lamp_r);
}
