/* Hand-written references for Alg. 1, written as a C programmer would, against the generated header's types.
 * bench/bench_codegen.py measures the generated mlca_step against both. */
#include "mlca_fsm.h"

mlca_state_t mlca_hand_return(mlca_state_t s, mlca_inputs_t in);
mlca_state_t mlca_hand_switch(mlca_state_t s, mlca_inputs_t in);

/* Early returns: the shortest source. */
mlca_state_t mlca_hand_return(mlca_state_t s, mlca_inputs_t in)
{
    if (!in.N) {
        return MLCA_IDLE;
    }
    switch (s) {
    case MLCA_IDLE:
        if (in.W) {
            return MLCA_WAITING;
        }
        if (in.L) {
            return MLCA_MOVING_LEFT;
        }
        if (in.R) {
            return MLCA_MOVING_RIGHT;
        }
        return MLCA_IDLE;
    case MLCA_WAITING:
        return (in.L || in.R) ? MLCA_IDLE : MLCA_WAITING;
    case MLCA_MOVING_LEFT:
        return in.L ? MLCA_MOVING_LEFT : MLCA_IDLE;
    case MLCA_MOVING_RIGHT:
        return in.R ? MLCA_MOVING_RIGHT : MLCA_IDLE;
    default:
        return MLCA_IDLE;
    }
}

/* One exit, the state kept unless a branch changes it. */
mlca_state_t mlca_hand_switch(mlca_state_t s, mlca_inputs_t in)
{
    mlca_state_t next = s;
    if (!in.N) {
        next = MLCA_IDLE;
    } else {
        switch (s) {
        case MLCA_IDLE:
            if (in.W) {
                next = MLCA_WAITING;
            } else if (in.L) {
                next = MLCA_MOVING_LEFT;
            } else if (in.R) {
                next = MLCA_MOVING_RIGHT;
            }
            break;
        case MLCA_WAITING:
            if (in.L || in.R) {
                next = MLCA_IDLE;
            }
            break;
        case MLCA_MOVING_LEFT:
            if (!in.L) {
                next = MLCA_IDLE;
            }
            break;
        case MLCA_MOVING_RIGHT:
            if (!in.R) {
                next = MLCA_IDLE;
            }
            break;
        default:
            next = MLCA_IDLE;
            break;
        }
    }
    return next;
}
