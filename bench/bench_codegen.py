"""Benchmark the generated C step against hand-written references of the same machine (Alg. 1, then MLCA-T).

Run on demand: `.venv/bin/python bench/bench_codegen.py [--steps N]`. Prints, side by side in one run:
- instructions per step on x86-64 (gcc -O2), counted by `valgrind --tool=callgrind` inside the step function
  only, over the same fixed input sequence for every candidate (instruction counts are repeatable, unlike time);
- Cortex-M4 .text bytes of the step with every function it calls (arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -Os,
  a link from the step with --gc-sections);
and the ratios generated / best hand-written reference and generated / the boolean pipeline's last code of the same
spec (bench/reference/boolean: every machine now goes through one pipeline, whose step takes a context). Target:
every ratio at most 1.0. Alg. 1's repair (spec/mlca_r.toml) is measured against its boolean code the same way.

MLCA-T (spec/mlca_t.toml, the whole decision function: L and R over gap and speed signals, the waiting timer)
compares the generated mlca_t_step with bench/reference/mlca_t_hand.c (gcc -O2 -ffp-contract=off). One driver,
written here, runs both in lockstep over a fixed pseudo-random sequence (splitmix64, fixed seed; mostly valid
samples, some boundary, out-of-range, NaN and infinite ones; N and U toggling; four valid param sets; a corrupted
mode now and then) and stops at the first step where their outputs or contexts differ; the whole object's .text
is printed too, since the generated object also holds the monitor and the param check.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from pathlib import Path

from figures import write_block  # run as a script: bench/ is on the path

ROOT = Path(__file__).resolve().parent.parent
GENERATED = ROOT / "generated" / "c"
REFERENCE = ROOT / "bench" / "reference"
BOOLEAN = REFERENCE / "boolean"
# label -> (step function, its source, the folder of the header it includes, whether it steps a context)
Candidate = tuple[str, Path, Path, bool]
CANDIDATES: dict[str, Candidate] = {
    "generated mlca_step": ("mlca_step", GENERATED / "mlca_fsm.c", GENERATED, True),
    "hand-written, early returns": ("mlca_hand_return", REFERENCE / "mlca_hand.c", GENERATED, False),
    "hand-written, single exit": ("mlca_hand_switch", REFERENCE / "mlca_hand.c", GENERATED, False),
    "boolean pipeline's mlca_step": ("mlca_step", BOOLEAN / "mlca_fsm.c", BOOLEAN, False),
}
REPAIR: dict[str, Candidate] = {
    "generated mlca_r_step": ("mlca_r_step", GENERATED / "mlca_r_fsm.c", GENERATED, True),
    "boolean pipeline's mlca_r_step": ("mlca_r_step", BOOLEAN / "mlca_r_fsm.c", BOOLEAN, False),
}


def sh(*args: str, cwd: Path | None = None) -> str:
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True, check=True)
    return done.stdout + done.stderr


MLCA_T_SEED = 0x4D4C43412D54  # "MLCA-T"
MLCA_T_CANDIDATES = {
    "generated mlca_t_step": ("mlca_t_step", GENERATED / "mlca_t_fsm.c"),
    "hand-written mlca_t_hand_step": ("mlca_t_hand_step", REFERENCE / "mlca_t_hand.c"),
}
MLCA_T_DRIVER = r"""
/* Runs mlca_t_step and mlca_t_hand_step in lockstep over STEPS fixed pseudo-random inputs and stops (exit 1) at
 * the first step where their outputs or contexts differ. Written by bench/bench_codegen.py. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include "mlca_t_fsm.h"
#include "mlca_t_hand.h"
#include "splitmix.h"


static double uniform(double hi) { return (double)(next() >> 11) * 0x1.0p-53 * hi; }

static unsigned long odd_samples = 0u;

/* Mostly a valid sample in [0, hi]; one in 24 a boundary, out-of-range, NaN or infinite one. */
static double sample(double hi)
{
    if (!one_in(24u)) {
        return uniform(hi);
    }
    odd_samples += 1u;
    switch (next() % 10u) {
    case 0u: return 0.0;
    case 1u: return -0.0;
    case 2u: return hi;
    case 3u: return hi * (1.0 + 0x1.0p-52); /* just above the range */
    case 4u: return -0x1.0p-1074; /* just below it */
    case 5u: return NAN;
    case 6u: return INFINITY;
    case 7u: return -INFINITY;
    case 8u: return 3.0; /* MIN_GAP's default */
    default: return 2.0 * hi + uniform(hi);
    }
}

typedef struct { double lead, follow, v_follow, v_lead; } lane_t;

/* RSS's distance for a vehicle at `rear` behind one at `front` (the spec's reach minus stop), as the code computes
 * it: a gap on it sits on a threshold of L or R. */
static double rss_edge(double rear, double front, const mlca_t_params_t *p)
{
    const double v_end = rear + p->RHO * p->ACCEL_MAX;
    return rear * p->RHO + p->ACCEL_MAX * p->RHO * p->RHO / 2.0 + v_end * v_end / (2.0 * p->BRAKE_MIN)
        - front * front / (2.0 * p->BRAKE_MAX);
}

static void new_lane(lane_t *l, double v, const mlca_t_params_t *p)
{
    l->lead = sample(1000.0);
    l->follow = sample(1000.0);
    l->v_follow = sample(70.0);
    l->v_lead = sample(70.0);
    if (one_in(16u)) { /* on a threshold of L or R */
        switch (next() % 3u) {
        case 0u: l->lead = rss_edge(v, l->v_lead, p); break;
        case 1u: l->follow = rss_edge(l->v_follow, v, p); break;
        default: l->follow = p->MIN_GAP; break;
        }
    }
}

static const mlca_t_params_t PARAMS[4] = {
    {20, 3.0, 1.0, 3.5, 4.0, 8.0}, /* the defaults */
    {1, 1.0, 0.5, 2.0, 3.0, 9.0},
    {100, 10.0, 3.0, 10.0, 1.0, 12.0},
    {7, 5.5, 0.2, 0.0, 8.0, 8.0},
};

static int same(const mlca_t_ctx_t *a, const mlca_t_ctx_t *b, const mlca_t_outputs_t *oa,
    const mlca_t_outputs_t *ob)
{
    return a->mode == b->mode && a->waited == b->waited
        && oa->command == ob->command;
}

int main(void)
{
    static const char *const names[4] = {"IDLE", "WAITING", "MOVING_LEFT", "MOVING_RIGHT"};
    unsigned long k, visits[4] = {0u, 0u, 0u, 0u}, changes[4][4] = {{0u}};
    unsigned long corrupted = 0u, waited_max = 0u;
    long long command_sum = 0;
    unsigned m, n;
    mlca_t_ctx_t cg, ch;
    mlca_t_outputs_t og = {0}, oh = {0};
    mlca_t_inputs_t in = {false, false, 0.0, 1000.0, 1000.0, 0.0, 0.0, 1000.0, 1000.0, 0.0, 0.0};
    lane_t left, right;
    mlca_t_init(&cg);
    mlca_t_hand_init(&ch);
    if (!same(&cg, &ch, &og, &oh)) {
        fprintf(stderr, "the initial contexts differ\n");
        return 1;
    }
    for (k = 0u; k < STEPS; ++k) {
        const mlca_t_params_t *p = &PARAMS[(k >> 16) & 3u];
        const unsigned before = (unsigned)cg.mode;
        const int calm = ((k >> 14) & 7u) == 7u; /* one block in 8: long needs over slow traffic, timers saturate */
        if (one_in(calm ? 4096u : 48u)) { /* the need comes and goes, urgency within it */
            in.N = !in.N;
        }
        in.U = in.N ? (in.U != one_in(32u)) : one_in(256u); /* now and then U without N (outside the assumption) */
        if (one_in(calm ? 512u : 16u)) {
            in.v = sample(70.0);
        }
        if (one_in(calm ? 512u : 12u)) {
            new_lane(&left, in.v, p);
            in.gap_lead_left = left.lead;
            in.gap_follow_left = left.follow;
            in.v_follow_left = left.v_follow;
            in.v_lead_left = left.v_lead;
        }
        if (one_in(calm ? 512u : 12u)) {
            new_lane(&right, in.v, p);
            in.gap_lead_right = right.lead;
            in.gap_follow_right = right.follow;
            in.v_follow_right = right.v_follow;
            in.v_lead_right = right.v_lead;
        }
        if ((k & 0xFFFFu) == 0xFFFFu) { /* a corrupted mode starts again from init */
            cg.mode = ch.mode = (mlca_t_state_t)(4u + (unsigned)(k >> 16) % 3u);
            corrupted += 1u;
        }
        mlca_t_step(&cg, &in, p, &og);
        mlca_t_hand_step(&ch, &in, p, &oh);
        if (!same(&cg, &ch, &og, &oh)) {
            fprintf(stderr,
                "step %lu: generated (mode %d, waited %d, command %lld) != "
                "hand-written (mode %d, waited %d, command %lld)\n",
                k, (int)cg.mode, (int)cg.waited, (long long)og.command,
                (int)ch.mode, (int)ch.waited, (long long)oh.command);
            return 1;
        }
        visits[(unsigned)cg.mode & 3u] += 1u;
        changes[before & 3u][(unsigned)cg.mode & 3u] += 1u;
        command_sum += (long long)og.command;
        waited_max += (cg.waited == 1000) ? 1u : 0u;
    }
    printf("mode visits IDLE %lu, WAITING %lu, MOVING_LEFT %lu, MOVING_RIGHT %lu; command sum %lld\n",
        visits[0], visits[1], visits[2], visits[3], command_sum);
    printf("mode changes");
    for (m = 0u; m < 4u; ++m) {
        for (n = 0u; n < 4u; ++n) {
            if (m != n && changes[m][n] != 0u) {
                printf(" %s->%s %lu", names[m], names[n], changes[m][n]);
            }
        }
    }
    printf("\nodd samples %lu, corrupted modes reset %lu, steps with waited at 1000 %lu\n",
        odd_samples, corrupted, waited_max);
    return 0;
}
"""


def mlca_t_driver(steps: int, work: Path) -> tuple[Path, str]:
    """Build the lockstep driver over both candidates and run it once natively: the trajectory, or abort."""
    source = work / "drive_mlca_t.c"
    source.write_text(MLCA_T_DRIVER)
    exe = work / "drive_mlca_t"
    sh("gcc", "-std=c99", "-O2", "-ffp-contract=off", f"-I{GENERATED}", f"-I{REFERENCE}",
       f"-DSEED=UINT64_C({MLCA_T_SEED:#x})", f"-DSTEPS={steps}ul", "-o", str(exe), str(source),
       *(str(src) for _, src in MLCA_T_CANDIDATES.values()))  # fmt: skip
    done = subprocess.run([str(exe)], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"MLCA-T: the generated and the hand-written step disagree, benchmark aborted:\n{done.stderr}")
    return exe, done.stdout.strip()


def callgrind_instructions(function: str, exe: Path, steps: int, work: Path) -> tuple[float, str]:
    """Instructions per step inside `function` (callgrind, collecting in it alone) over a run of `exe`, and what
    the run printed."""
    out_file = work / f"callgrind.{function}"
    done = subprocess.run(
        ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out_file}", f"--toggle-collect={function}", str(exe)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"{function}: the run under callgrind failed, benchmark aborted:\n{done.stderr}")
    total = int(re.search(r"Collected : (\d+)", done.stderr).group(1))  # type: ignore[union-attr]
    return total / steps, done.stdout.strip()


def step_text_bytes(function: str, source: Path, work: Path, include: Path = GENERATED) -> tuple[int, int]:
    """Cortex-M4 .text of the step with every function it calls, and of the whole object."""
    obj = work / f"{function}.arm.o"
    elf = work / f"{function}.arm.elf"
    sh("arm-none-eabi-gcc", "-std=c99", "-mcpu=cortex-m4", "-mthumb", "-Os", "-ffp-contract=off",
       "-ffunction-sections", "-fdata-sections", f"-I{include}", f"-I{REFERENCE}", "-c", "-o", str(obj),
       str(source))  # fmt: skip
    sh("arm-none-eabi-gcc", "-mcpu=cortex-m4", "-mthumb", "-nostdlib", "-Wl,--gc-sections", f"-Wl,-e,{function}",
       "-Wl,--unresolved-symbols=ignore-all", "-o", str(elf), str(obj))  # fmt: skip

    def text(path: Path) -> int:
        sections = re.findall(r"^(\.text\S*)\s+(\d+)", sh("arm-none-eabi-size", "-A", str(path)), re.MULTILINE)
        return sum(int(size) for _, size in sections)

    return text(elf), text(obj)


def mlca_t_section(steps: int, write_docs: bool = False) -> None:
    rows = {}
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        exe, trajectory = mlca_t_driver(steps, work)
        for label, (function, source) in MLCA_T_CANDIDATES.items():
            per_step, replay = callgrind_instructions(function, exe, steps, work)
            assert replay == trajectory, f"the run under callgrind differs from the native one: {replay}"
            rows[label] = (per_step, *step_text_bytes(function, source, work))
    print(f"\nMLCA-T (spec/mlca_t.toml): {steps} steps, generated and hand-written in lockstep, identical outputs")
    print("and contexts at every step (gcc -O2 -ffp-contract=off)")
    print(trajectory + "\n")
    print(f"{'candidate':30} {'instructions/step':>18} {'Cortex-M4 .text B':>18} {'whole .o .text B':>18}")
    for label, (per_step, size, whole) in rows.items():
        print(f"{label:30} {per_step:18.2f} {size:18d} {whole:18d}")
    gen, hand = rows["generated mlca_t_step"], rows["hand-written mlca_t_hand_step"]
    print(f"\nratio generated / hand-written: instructions {gen[0] / hand[0]:.3f}, .text {gen[1] / hand[1]:.3f}")
    print("(.text: the step and the functions it calls, libgcc's soft-float helpers left out)")
    print("target: both at most 1.0")
    if write_docs:
        lines = ["| candidate | instructions / step | Cortex-M4 .text (step and callees) |", "|---|---|---|"]
        lines += [f"| {label} | {per_step:.2f} | {size:,} B |" for label, (per_step, size, _) in rows.items()]
        ratios = f"instructions **{gen[0] / hand[0]:.3f}**, .text **{gen[1] / hand[1]:.3f}**"
        lines += ["", f"Ratio generated / hand-written: {ratios}."]
        write_block("mlca-t", lines, f"bench/bench_codegen.py --steps {steps} --write-docs")


DRIVER = r"""
/* Steps a candidate over a fixed pseudo-random input sequence (a 32-bit LCG with a fixed seed, so that callgrind
 * counts the same work for every candidate) and prints the visits per state: the generated step over a context
 * (-DCONTEXT), or a step by value, STEP_FN. Written by bench/bench_codegen.py. */
#include <stdio.h>
#include "{P}_fsm.h"

#ifndef CONTEXT
{P}_state_t STEP_FN({P}_state_t s, {P}_inputs_t in);
#endif

int main(void)
{
    unsigned long k;
    unsigned int seed = 12345u;
    unsigned long visits[4] = {0u, 0u, 0u, 0u};
#ifdef CONTEXT
    {P}_ctx_t c;
    {P}_outputs_t o;
    {P}_init(&c);
#else
    {P}_state_t s = {M}_INITIAL;
#endif
    for (k = 0u; k < STEPS; ++k) {
        {P}_inputs_t in;
        unsigned int mode;
        seed = seed * 1103515245u + 12345u;
        in.N = ((seed >> 16) & 7u) != 0u; /* a lane change is needed 7 steps in 8 */
        in.W = ((seed >> 19) & 1u) != 0u;
        in.L = ((seed >> 20) & 3u) == 0u;
        in.R = ((seed >> 22) & 3u) == 0u;
#ifdef CONTEXT
        {P}_step(&c, &in, &{P}_DEFAULT_PARAMS, &o);
        mode = (unsigned)c.mode;
#else
        s = STEP_FN(s, in);
        mode = (unsigned)s;
#endif
        visits[mode & 3u] += 1u;
    }
    printf("%lu %lu %lu %lu\n", visits[0], visits[1], visits[2], visits[3]);
    return 0;
}
"""


def measure(module: str, candidate: Candidate, steps: int, work: Path) -> tuple[float, int, str]:
    """Instructions per step, Cortex-M4 .text of the step with what it calls, and the state visits."""
    function, source, include, context = candidate
    tag = f"{function}_{source.parent.name}_{source.stem}"
    driver = work / f"drive_{tag}.c"
    driver.write_text(DRIVER.replace("{P}", module).replace("{M}", module.upper()))
    exe = work / f"drive_{tag}"
    sh("gcc", "-std=c99", "-O2", f"-I{include}", "-DCONTEXT" if context else f"-DSTEP_FN={function}",
       f"-DSTEPS={steps}u", "-o", str(exe), str(driver), str(source))  # fmt: skip
    per_step, visits = callgrind_instructions(function, exe, steps, work)
    (work / tag).mkdir(exist_ok=True)
    size, _ = step_text_bytes(function, source, work / tag, include)
    return per_step, size, visits


def table(module: str, candidates: dict[str, Candidate], steps: int, work: Path) -> dict[str, tuple[float, int, str]]:
    rows = {label: measure(module, c, steps, work) for label, c in candidates.items()}
    visits = {v[2] for v in rows.values()}
    assert len(visits) == 1, f"the candidates disagree on the trajectory: {rows}"
    print(f"{steps} steps, same trajectory for every candidate (state visits {visits.pop()})\n")
    print(f"{'candidate':32} {'instructions/step':>18} {'Cortex-M4 .text B':>18}")
    for label, (per_step, size, _) in rows.items():
        print(f"{label:32} {per_step:18.2f} {size:18d}")
    return rows


Row = tuple[float, int, str]


def ratio(what: str, a: Row, b: Row) -> str:
    """Print the two ratios of `a` to `b`, and return them as the docs write them."""
    print(f"ratio generated / {what}: instructions {a[0] / b[0]:.3f}, .text {a[1] / b[1]:.3f}")
    return f"generated / {what}: instructions **{a[0] / b[0]:.3f}**, .text **{a[1] / b[1]:.3f}**"


def boolean_lines(alg1: dict[str, Row], repair: dict[str, Row], ratios: list[str]) -> list[str]:
    """The docs' table of Alg. 1 and the repair, and the ratios under it."""
    lines = ["| candidate | instructions / step | Cortex-M4 .text |", "|---|---|---|"]
    lines += [f"| {label} | {row[0]:.2f} | {row[1]} B |" for rows in (alg1, repair) for label, row in rows.items()]
    return [*lines, "", *(f"Ratio {r}." for r in ratios)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=1_000_000, help="steps of the fixed input sequence")
    parser.add_argument("--write-docs", action="store_true", help="write the tables into their docs page")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        print("Alg. 1 (spec/mlca.toml)")
        rows = table("mlca", CANDIDATES, args.steps, work)
        gen = rows["generated mlca_step"]
        hand = [v for k, v in rows.items() if k.startswith("hand")]
        best = (min(v[0] for v in hand), min(v[1] for v in hand), "")
        print()
        ratios = [
            ratio("best hand-written", gen, best),
            ratio("the boolean pipeline's", gen, rows["boolean pipeline's mlca_step"]),
        ]
        print("\nThe repair (spec/mlca_r.toml)")
        repair = table("mlca_r", REPAIR, args.steps, work)
        print()
        mine, theirs = repair["generated mlca_r_step"], repair["boolean pipeline's mlca_r_step"]
        ratios.append(ratio("the boolean pipeline's", mine, theirs).replace("generated", "generated repair", 1))
        print("target: every ratio at most 1.0")
    if args.write_docs:
        write_block(
            "mlca", boolean_lines(rows, repair, ratios), f"bench/bench_codegen.py --steps {args.steps} --write-docs"
        )
    mlca_t_section(args.steps, args.write_docs)


if __name__ == "__main__":
    main()
