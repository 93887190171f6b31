/* Hand-written reference for MLCA-T (spec/mlca_t.toml), over the generated header's types.
 * bench/bench_codegen.py measures the generated mlca_t_step against mlca_t_hand_step. */
#ifndef MLCA_T_HAND_H
#define MLCA_T_HAND_H

#include "mlca_t_fsm.h"

/* The context before the first step (the same as mlca_t_init's). */
void mlca_t_hand_init(mlca_t_ctx_t *c);

/* One step, the same outputs and the same context after it as mlca_t_step, for every input. */
void mlca_t_hand_step(mlca_t_ctx_t *c, const mlca_t_inputs_t *in, const mlca_t_params_t *p, mlca_t_outputs_t *o);

#endif /* MLCA_T_HAND_H */
