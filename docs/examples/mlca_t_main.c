/* A firmware main loop around the generated MLCA-T decision function (generated/c/mlca_t_fsm.c).
 * The sensor and actuator functions are the integrator's; here they are stubs that read nothing, so that the
 * example builds and runs on the host and cross-compiles for a Cortex-M4. Build with -ffp-contract=off (the
 * default of gcc -std=c99), as the generated code asks. */
#include <stdbool.h>
#include <stdint.h>

#include "mlca_t_fsm.h"

/* The integrator's: one sample of every input, taken at the start of a 0.1 s control period. */
static void read_sensors(mlca_t_inputs_t *in, uint32_t tick)
{
    in->N = tick >= 5U;                /* the planner wants a lane change from tick 5 on */
    in->U = false;                     /* the lane does not end */
    in->v = 25.0;                      /* m/s */
    in->gap_lead_left = 1000.0;        /* nobody sensed ahead on the left */
    in->gap_follow_left = 110.0;       /* RSS asks for 106.1 m from a follower at 27 m/s */
    in->v_follow_left = 27.0;
    in->v_lead_left = 0.0;             /* no leader: a standing vehicle 1000 m ahead */
    in->gap_lead_right = 1000.0;
    in->gap_follow_right = 1000.0;
    in->v_follow_right = 0.0;
    in->v_lead_right = 0.0;
}

/* The integrator's: hand the command to the lateral controller (+1 left, -1 right, 0 keep the lane). */
static int64_t commanded;
static void actuate(const mlca_t_outputs_t *out) { commanded = out->command; }

int main(void)
{
    mlca_t_ctx_t ctx;
    mlca_t_inputs_t in;
    mlca_t_outputs_t out;
    uint32_t tick;
    int status = 0;
    if (!mlca_t_params_valid(&mlca_t_DEFAULT_PARAMS)) {
        status = 1;
    } else {
        mlca_t_init(&ctx);
        for (tick = 0U; tick < 40U; tick++) { /* on a vehicle: forever, once per period */
            read_sensors(&in, tick);
            mlca_t_step(&ctx, &in, &mlca_t_DEFAULT_PARAMS, &out);
            actuate(&out);
        }
        status = (commanded == 1) ? 0 : 2; /* by now the deferred change to the left is under way */
    }
    return status;
}
