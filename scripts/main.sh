#!/usr/bin/env bash
# Set up, then run the main job on the shipped specs:
#   1. prove every property of the canonical machine, the repair, MLCA-T (the whole decision function) and the
#      paper's other two readings, and of the V2V protocols and their networks of AVs (spec/v2v, out/check_v2v.json);
#   2. generate the Python and C99 code of the three deterministic machines into generated/;
#   3. prove and test that code against its spec (compilers, exhaustive comparison, Frama-C WP, cppcheck,
#      the Cortex-M4 cross build, sanitizers; MLCA-T's bit for bit against z3's semantics, its WP without the monitor);
#   4. generate the requirements-based test suites of the three machines to MC/DC, measure their coverage of the
#      generated Python and C, and run them on a Cortex-M4 under QEMU against the host (out/tests/);
#   5. run the paper's comparison closed loop in SUMO on a short version of its scenario: the three generated C
#      controllers and every comparison model, one and three AVs, two seeds each, on the needs of SUMO's own
#      lane-change model (out/sim.sqlite, made anew), and draw it beside the paper's figures, with the transition
#      coverage, the shadow mode and the safety checks (out/comparison/report.md);
#   6. replay in SUMO the counterexamples of MLCA-T's gap-rule lemmas (the old time-gap rule against RSS;
#      out/replay.json), and of the first V2V protocol (its two AVs into one gap; out/replay_v2v.json), the
#      same scenes driven by the repaired protocol (out/replay_v2v_repaired.json), and three AVs of each V2V
#      protocol, each driving its own generated instance, through a lossy radio (out/sim_v2v.sqlite), a perfect
#      one and none, compared side by side (out/channels/channels.md);
#   7. package it all as safety-case evidence for the repaired controller (out/evidence/index.html), and the
#      evidence of MLCA-T, the machine with data: its proofs, its generated code and its tests' coverage, its
#      closed-loop runs with their transition coverage, and its physical-safety section (out/evidence_t/index.html),
#      and the evidence of the repaired V2V network: its goals, each vehicle's, the channels, the code, the lossy
#      closed loop and the replays (out/evidence_v2v/index.html).
# Reports go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mkdir -p out
.venv/bin/mlca-verify check spec/mlca.toml spec/mlca_r.toml spec/mlca_t.toml spec/paper/*.toml --json out/check.json
.venv/bin/mlca-verify check spec/v2v/*.toml --quiet --json out/check_v2v.json
.venv/bin/mlca-verify gen spec/mlca.toml spec/mlca_r.toml spec/mlca_t.toml
.venv/bin/mlca-verify conform spec/mlca.toml spec/mlca_r.toml spec/mlca_t.toml --json out/conform.json
.venv/bin/mlca-verify tests spec/mlca.toml spec/mlca_r.toml spec/mlca_t.toml --out out/tests
rm -f out/sim.sqlite  # made anew: a database of an older layout is refused, and this matrix takes a minute
.venv/bin/mlca-sim sweep --matrix paper --avs 1,3 --runs 2 --jobs 2 \
    --scenario sim_check/scenarios/short.toml --db out/sim.sqlite
.venv/bin/mlca-sim report --db out/sim.sqlite --out out/comparison
.venv/bin/mlca-verify evidence spec/mlca_r.toml --db out/sim.sqlite --out out/evidence
.venv/bin/mlca-sim replay out/check.json --json out/replay.json
# the V2V protocols closed loop: the first protocol's counterexamples as scenes in SUMO (they collide), the same
# scenes driven by the repaired protocol, and three AVs of each protocol through a lossy radio
.venv/bin/mlca-sim replay out/check_v2v.json --json out/replay_v2v.json
.venv/bin/mlca-sim replay out/check_v2v.json --network spec/v2v/gap_repaired.toml --json out/replay_v2v_repaired.json
rm -f out/sim_v2v.sqlite out/sim_v2v_off.sqlite out/sim_v2v_perfect.sqlite
.venv/bin/mlca-sim sweep --controller mlca_t_v2v-c,mlca_t_claim-c --avs 3 --runs 4 --jobs 2 \
    --scenario sim_check/scenarios/v2v_lossy.toml --db out/sim_v2v.sqlite
for channel in off perfect; do
    .venv/bin/mlca-sim sweep --controller mlca_t_v2v-c,mlca_t_claim-c --avs 3 --runs 4 --jobs 2 \
        --scenario "sim_check/scenarios/v2v_$channel.toml" --db "out/sim_v2v_$channel.sqlite"
done
.venv/bin/mlca-sim channels --db off=out/sim_v2v_off.sqlite --db perfect=out/sim_v2v_perfect.sqlite \
    --db lossy=out/sim_v2v.sqlite --out out/channels
.venv/bin/mlca-verify evidence spec/v2v/gap_repaired.toml --db out/sim_v2v.sqlite \
    --replay out/replay_v2v_repaired.json --out out/evidence_v2v
.venv/bin/mlca-verify evidence spec/mlca_t.toml --db out/sim.sqlite --replay out/replay.json --out out/evidence_t
echo "main: reports in out/check.json, out/check_v2v.json, out/conform.json, out/tests/, out/sim.sqlite, out/comparison/report.md, out/replay.json," \
    "out/replay_v2v.json, out/replay_v2v_repaired.json, out/sim_v2v*.sqlite, out/channels/," \
    "out/evidence/, out/evidence_t/ and out/evidence_v2v/ (open out/evidence/index.html)"
