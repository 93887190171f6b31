/* Hand-written reference for tests/machines/thermostat_1hz.toml, as an embedded C programmer would write it: a
 * switch over an 8-bit state, the sensor check written once, a 16-bit dwell timer, an 8-bit relay output. */
#include "thermostat_hand.h"

#define TH_OFF 0u
#define TH_HEATING 1u
#define TH_FAULT 2u
#define ROOM_MIN (-20.0)
#define ROOM_MAX 50.0
#define DWELL_MAX 3600u

void thermostat_hand_init(thermostat_hand_t *h)
{
    h->state = TH_OFF;
    h->dwell = 0u;
}

void thermostat_hand_step(thermostat_hand_t *h, const thermostat_inputs_t *in, const thermostat_params_t *p,
    thermostat_hand_out_t *o)
{
    const double room = in->room;
    const bool ok = (ROOM_MIN <= room) && (room <= ROOM_MAX);
    uint8_t next = h->state;
    switch (h->state) {
    case TH_OFF:
        if (!ok) {
            next = TH_FAULT;
        } else if ((room < (p->SET - p->BAND)) && ((int32_t)h->dwell >= (p->MIN_OFF - 1))) {
            next = TH_HEATING;
        } else {
            /* stays off */
        }
        break;
    case TH_HEATING:
        if (!ok) {
            next = TH_FAULT;
        } else if ((room > (p->SET + p->BAND)) && ((int32_t)h->dwell >= (p->MIN_ON - 1))) {
            next = TH_OFF;
        } else {
            /* keeps heating */
        }
        break;
    default:
        if (ok) {
            next = TH_OFF;
        }
        break;
    }
    if (next != h->state) {
        h->state = next;
        h->dwell = 0u;
    } else if (h->dwell < DWELL_MAX) {
        h->dwell += 1u;
    } else {
        /* saturated */
    }
    o->boiler = (next == TH_HEATING) ? 1u : 0u;
}

int thermostat_hand_agrees(const thermostat_hand_t *h, const thermostat_hand_out_t *o, const thermostat_ctx_t *c,
    const thermostat_outputs_t *go)
{
    static const thermostat_state_t modes[3] = {THERMOSTAT_OFF, THERMOSTAT_HEATING, THERMOSTAT_SENSOR_FAULT};
    return (h->state < 3u) && (c->mode == modes[h->state]) && (c->dwell == (int32_t)h->dwell)
        && (go->boiler == (int64_t)o->boiler);
}
