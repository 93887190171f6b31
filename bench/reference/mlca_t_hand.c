/* Hand-written reference for MLCA-T (spec/mlca_t.toml), written as an embedded C programmer would, against the
 * generated header's types. It computes the same outputs and the same context as the generated mlca_t_step for
 * every input: the same binary64 operations in the same order (build with -ffp-contract=off), the same validity
 * gating of L and R, the same saturating timers. bench/bench_codegen.py checks this at every step of its run. */
#include "mlca_t_hand.h"

#define V_MAX 70.0
#define GAP_MAX 1000.0
#define TIMER_MAX 1000

/* A sample is valid inside [0, hi]; NaN fails both comparisons. */
static bool in_range(double x, double hi)
{
    return (0.0 <= x) && (x <= hi);
}

/* The larger of MIN_GAP and a distance (as the spec's max: MIN_GAP unless the distance is larger). */
static double at_least_min_gap(double d, const mlca_t_params_t *p)
{
    return (d > p->MIN_GAP) ? d : p->MIN_GAP;
}

/* RSS (Definition 1): how far a vehicle at `speed` travels until it stops when it accelerates at ACCEL_MAX for
 * the response time RHO and then brakes at BRAKE_MIN. */
static double reach(double speed, const mlca_t_params_t *p)
{
    const double v_end = speed + (p->RHO * p->ACCEL_MAX);
    return ((speed * p->RHO) + (((p->ACCEL_MAX * p->RHO) * p->RHO) / 2.0)) + ((v_end * v_end) / (2.0 * p->BRAKE_MIN));
}

/* RSS: the shortest distance a vehicle at `speed` needs to stop, braking at BRAKE_MAX. */
static double stop(double speed, const mlca_t_params_t *p)
{
    return (speed * speed) / (2.0 * p->BRAKE_MAX);
}

/* L (left lane) or R (right lane): false when a sample it reads is invalid. */
static bool lane_safe(double v, double gap_lead, double v_lead, double gap_follow, double v_follow,
    const mlca_t_params_t *p)
{
    if (!(in_range(gap_lead, GAP_MAX) && in_range(v, V_MAX) && in_range(v_lead, V_MAX)
            && in_range(gap_follow, GAP_MAX) && in_range(v_follow, V_MAX))) {
        return false;
    }
    return (gap_lead >= at_least_min_gap(reach(v, p) - stop(v_lead, p), p))
        && (gap_follow >= at_least_min_gap(reach(v_follow, p) - stop(v, p), p));
}

static bool left_safe(const mlca_t_inputs_t *in, const mlca_t_params_t *p)
{
    return lane_safe(in->v, in->gap_lead_left, in->v_lead_left, in->gap_follow_left, in->v_follow_left, p);
}

static bool right_safe(const mlca_t_inputs_t *in, const mlca_t_params_t *p)
{
    return lane_safe(in->v, in->gap_lead_right, in->v_lead_right, in->gap_follow_right, in->v_follow_right, p);
}

void mlca_t_hand_init(mlca_t_ctx_t *c)
{
    c->mode = MLCA_T_IDLE;
    c->waited = 0;
}

void mlca_t_hand_step(mlca_t_ctx_t *c, const mlca_t_inputs_t *in, const mlca_t_params_t *p, mlca_t_outputs_t *o)
{
    mlca_t_state_t mode = c->mode;
    int32_t waited = (c->waited < TIMER_MAX) ? (c->waited + 1) : TIMER_MAX;

    if ((unsigned)mode > (unsigned)MLCA_T_MOVING_RIGHT) { /* a corrupted context starts again */
        mlca_t_hand_init(c);
        o->command = 0;
        return;
    }
    if (!in->N) { /* reset */
        mode = MLCA_T_IDLE;
        waited = 0;
    } else {
        switch (mode) {
        case MLCA_T_IDLE:
        case MLCA_T_WAITING:
            if ((mode == MLCA_T_IDLE) && !in->U) { /* idle_wait */
                mode = MLCA_T_WAITING;
                waited = 1;
            } else if (in->U || (c->waited >= p->T_MIN)) { /* urgent, or W has run out in WAITING */
                if (left_safe(in, p)) {
                    mode = MLCA_T_MOVING_LEFT;
                } else if (right_safe(in, p)) {
                    mode = MLCA_T_MOVING_RIGHT;
                }
            }
            break;
        case MLCA_T_MOVING_LEFT:
            if (!left_safe(in, p)) { /* left_abort */
                mode = MLCA_T_IDLE;
            }
            break;
        default: /* MLCA_T_MOVING_RIGHT */
            if (!right_safe(in, p)) { /* right_abort */
                mode = MLCA_T_IDLE;
            }
            break;
        }
    }
    c->mode = mode;
    c->waited = waited;
    o->command = (mode == MLCA_T_MOVING_LEFT) ? 1 : ((mode == MLCA_T_MOVING_RIGHT) ? -1 : 0);
}
