"""Benchmark the generated C step of corpus machines against versions written by hand with the same behaviour.

Run on demand: `.venv/bin/python bench/bench_corpus_code.py [--steps N] [--only NAME]`. For each machine below
(a 1 kHz debounced pump trip, a 1 Hz thermostat with hysteresis and minimum on and off times, a 100 Hz turn
signal flasher), it generates the C from tests/machines/ into a temporary folder and builds one driver, written
here from the machine's inputs and signals, that runs the generated `<module>_step` and the hand-written
`<name>_hand_step` (bench/reference/corpus/) in lockstep over the same fixed pseudo-random input sequence
(splitmix64, fixed seed; each input held for a number of steps fitting the machine's timers; one sample in 24
odd: on a bound, outside its range, NaN or infinite) with the spec's default params. The run stops at the first
step where the mode, a variable or an output differs. It then prints, side by side from the same run:
- instructions per step on x86-64 (gcc -O2 -ffp-contract=off), counted by `valgrind --tool=callgrind` inside
  each step function only (instruction counts are repeatable, unlike time);
- Cortex-M4 .text of each step with every function it calls (arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -Os,
  linked from the step with --gc-sections; libgcc's soft-float helpers left out);
and the ratios generated / hand-written. Target: both at most 1.3.

The hand-written versions keep what the machine's behaviour needs and nothing else: no registers for the
properties' prev() (neither does the generated step, where a register reads the context alone), narrow integer
types, each test made once a step. They are the yardstick, not a fast path: the toolkit never uses them.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from bench_codegen import callgrind_instructions  # run as a script: bench/ is on the path
from figures import write_block
from mlca_verify.model import Machine
from mlca_verify.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
REFERENCE = ROOT / "bench" / "reference" / "corpus"

SEED = 0x434F52505553  # "CORPUS"


@dataclass(frozen=True)
class Bench:
    spec: str  # under tests/machines/
    hand: str  # the reference's prefix under bench/reference/corpus/
    hold: dict[str, int]  # steps an input or signal is held on average (every other: DEFAULT_HOLD)
    keep: str = ""  # C run after each draw that keeps the inputs within the spec's assumptions


DEFAULT_HOLD = 64
BENCHES = (
    # hot spells longer than the 1,000-sample debounce, a reset held now and then
    Bench("pump_debounce_1khz", "pump", {"temp": 2500, "reset": 3000}),
    # the room moves across the band more slowly than the 180-step minimum on and off times
    Bench("thermostat_1hz", "thermostat", {"room": 300}),
    # the stalk and the hazard switch held for seconds, the lamp current read anew every few steps
    Bench(
        "flasher_100hz",
        "flasher",
        {"stalk_left": 400, "stalk_right": 400, "hazard": 1500, "lamp_current": 8},
        "if (in.stalk_left && in.stalk_right) { in.stalk_right = false; }",  # one-stalk-position
    ),
)

DRIVER = r"""
/* Runs MODULE_step and HAND_step in lockstep over STEPS fixed pseudo-random inputs and stops (exit 1) at the first
 * step where they disagree. Written by bench/bench_corpus_code.py. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include "%(header)s"
#include "%(hand)s_hand.h"
#include "splitmix.h"


static double uniform(double lo, double hi) { return lo + (double)(next() >> 11) * 0x1.0p-53 * (hi - lo); }

static unsigned long odd_samples = 0u;

/* Mostly a valid sample in [lo, hi]; one in 24 on a bound, just outside, NaN or infinite. */
static double sample(double lo, double hi)
{
    if (!one_in(24u)) {
        return uniform(lo, hi);
    }
    odd_samples += 1u;
    switch (next() %% 8u) {
    case 0u: return lo;
    case 1u: return hi;
    case 2u: return nextafter(hi, INFINITY);
    case 3u: return nextafter(lo, -INFINITY);
    case 4u: return NAN;
    case 5u: return INFINITY;
    case 6u: return -INFINITY;
    default: return hi + (hi - lo) * uniform(0.0, 1.0);
    }
}

int main(void)
{
    static const char *const names[%(states)d] = {%(names)s};
    unsigned long k, visits[%(states)d] = {0u}, changes = 0u;
    %(module)s_ctx_t c;
    %(module)s_inputs_t in = {0};
    %(module)s_outputs_t o = {0};
    %(hand)s_hand_t h;
    %(hand)s_hand_out_t ho;
    const %(module)s_params_t *p = &%(module)s_DEFAULT_PARAMS;
    unsigned m;
    %(module)s_init(&c);
    %(hand)s_hand_init(&h);
%(first)s
    for (k = 0u; k < STEPS; ++k) {
        const unsigned before = (unsigned)c.mode;
%(inputs)s
        %(module)s_step(&c, &in, p, &o);
        %(hand)s_hand_step(&h, &in, p, &ho);
        if (!%(hand)s_hand_agrees(&h, &ho, &c, &o)) {
            fprintf(stderr, "step %%lu: the generated and the hand-written step disagree (generated mode %%d)\n", k,
                (int)c.mode);
            return 1;
        }
        visits[(unsigned)c.mode %% %(states)du] += 1u;
        changes += ((unsigned)c.mode != before) ? 1u : 0u;
    }
    printf("mode visits");
    for (m = 0u; m < %(states)du; ++m) {
        printf(" %%s %%lu", names[m], visits[m]);
    }
    printf("; %%lu mode changes, %%lu odd samples\n", changes, odd_samples);
    return 0;
}
"""


def sh(*args: str) -> str:
    done = subprocess.run(args, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{args[0]} failed, benchmark aborted:\n{done.stdout}{done.stderr}")
    return done.stdout + done.stderr


def _hold(b: Bench, name: str) -> int:
    return b.hold.get(name, DEFAULT_HOLD)


def _inputs(m: Machine, b: Bench) -> tuple[str, str]:
    """The driver's lines that draw the first inputs, and those that change them during the run."""
    first, each = [], []
    for i in m.inputs:
        first.append(f"    in.{i.name} = one_in(2u);")
        each.append(f"        if (one_in({_hold(b, i.name)}u)) {{ in.{i.name} = !in.{i.name}; }}")
    for s in m.signals:
        lo, hi = (float(x) for x in s.range)
        draw = f"in.{s.name} = sample({lo!r}, {hi!r});"
        first.append(f"    {draw}")
        each.append(f"        if (one_in({_hold(b, s.name)}u)) {{ {draw} }}")
    if b.keep:
        first.append(f"    {b.keep}")
        each.append(f"        {b.keep}")
    return "\n".join(first), "\n".join(each)


def driver(m: Machine, b: Bench, module: str) -> str:
    first, each = _inputs(m, b)
    return DRIVER % {
        "header": f"{module}_fsm.h",
        "hand": b.hand,
        "module": module,
        "states": len(m.states),
        "names": ", ".join(f'"{s}"' for s in m.states),
        "first": first,
        "inputs": each,
    }


def definitions_once(source: str, module: str) -> str:
    """The generated C with every definition the dispatch and the updates still call (those the generator does
    not compute once itself, see `codegen.once`) computed before the dispatch, whether the step reads it or not,
    into a file-scope variable they read instead (a measurement only)."""
    head, cut, body = source.partition(f"static int {module}_fired_")
    names = sorted(set(re.findall(rf"{module}_def_(\w+)\(c, i, p\)", body)))
    kinds = {n: re.search(rf"static (\w+) {module}_def_{n}\(", head).group(1) for n in names}  # type: ignore[union-attr]
    for n in names:
        body = body.replace(f"{module}_def_{n}(c, i, p)", f"once_{n}")
    computed = "".join(f"    once_{n} = {module}_def_{n}(c, i, p);\n" for n in names)
    dispatch = f"    const int fired = {module}_fired(c, i, p);"
    body = body.replace(dispatch, computed + dispatch)
    return head + "".join(f"static {kinds[n]} once_{n};\n" for n in names) + cut + body


VARIANTS: dict[str, Callable[[str, str], str]] = {
    "every definition first": definitions_once,
}

CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off")
ARM = ("-std=c99", "-mcpu=cortex-m4", "-mthumb", "-Os", "-ffp-contract=off", "-ffunction-sections", "-fdata-sections")


def generate(b: Bench, work: Path) -> tuple[Path, str, Machine]:
    """The machine's generated C source, its module name and the machine."""
    spec = ROOT / "tests" / "machines" / f"{b.spec}.toml"
    generated = work / b.spec
    sh(sys.executable, "-m", "mlca_verify", "gen", "--out", str(generated), str(spec))
    source = next((generated / "c").glob("*_fsm.c"))
    return source, source.name.removesuffix("_fsm.c"), load_spec(spec).machine


def build(b: Bench, machine: Machine, source: Path, steps: int, work: Path) -> tuple[Path, str]:
    """Build the lockstep driver over `source` and run it once natively: the trajectory, or abort."""
    module = source.name.removesuffix("_fsm.c")
    drive = work / f"drive_{b.spec}.c"
    drive.write_text(driver(machine, b, module))
    exe = work / f"drive_{b.spec}_{source.parent.parent.name}"
    hand = REFERENCE / f"{b.hand}_hand.c"
    sh("gcc", *CFLAGS, f"-I{source.parent}", f"-I{REFERENCE}", f"-I{REFERENCE.parent}", f"-DSEED=UINT64_C({SEED:#x})",
       f"-DSTEPS={steps}ul", "-o", str(exe), str(drive), str(source), str(hand), "-lm")  # fmt: skip
    return exe, sh(str(exe)).strip()


def text_bytes(function: str, source: Path, include: Path, work: Path) -> int:
    """Cortex-M4 .text of `function` and every function it calls."""
    obj, elf = work / f"{function}.arm.o", work / f"{function}.arm.elf"
    sh("arm-none-eabi-gcc", *ARM, f"-I{include}", f"-I{REFERENCE}", "-c", "-o", str(obj), str(source))
    sh("arm-none-eabi-gcc", "-mcpu=cortex-m4", "-mthumb", "-nostdlib", "-Wl,--gc-sections", f"-Wl,-e,{function}",
       "-Wl,--unresolved-symbols=ignore-all", "-o", str(elf), str(obj))  # fmt: skip
    sections = re.findall(r"^(\.text\S*)\s+(\d+)", sh("arm-none-eabi-size", "-A", str(elf)), re.MULTILINE)
    return sum(int(size) for _, size in sections)


def measure(b: Bench, steps: int, work: Path, variants: bool) -> tuple[str, dict[str, tuple[float, int]]]:
    source, module, machine = generate(b, work)
    exe, trajectory = build(b, machine, source, steps, work)
    rows = {}

    def row(label: str, function: str, file: Path, driven: Path) -> None:
        per_step, replay = callgrind_instructions(function, driven, steps, work)
        if replay != trajectory:
            raise SystemExit(f"{b.spec}: {label}: the run under callgrind differs from the native one:\n{replay}")
        rows[label] = (per_step, text_bytes(function, file, source.parent, work))

    row(f"generated {module}_step", f"{module}_step", source, exe)
    row(f"hand-written {b.hand}_hand_step", f"{b.hand}_hand_step", REFERENCE / f"{b.hand}_hand.c", exe)
    for label, edit in VARIANTS.items() if variants else ():
        folder = work / label.replace(" ", "_").replace("()", "") / "c"
        folder.mkdir(parents=True)
        shutil.copy2(source.with_suffix(".h"), folder)
        edited = folder / source.name
        edited.write_text(edit(source.read_text(), module))
        driven, _ = build(b, machine, edited, steps, work)
        row(f"generated, {label}", f"{module}_step", edited, driven)
    return trajectory, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=1_000_000, help="steps of the fixed input sequence")
    parser.add_argument("--only", choices=[b.spec for b in BENCHES], help="one machine only")
    parser.add_argument(
        "--variants", action="store_true", help="also measure the generated C edited: " + ", ".join(VARIANTS)
    )
    parser.add_argument("--write-docs", action="store_true", help="write the table into its docs page")
    args = parser.parse_args()
    print(f"{args.steps} steps a machine, generated and hand-written in lockstep with identical modes, variables")
    print("and outputs at every step (gcc -O2 -ffp-contract=off; Cortex-M4 .text of the step and its callees)")
    summary = []
    with tempfile.TemporaryDirectory() as folder:
        for b in BENCHES:
            if args.only and b.spec != args.only:
                continue
            work = Path(folder) / b.spec
            work.mkdir()
            trajectory, rows = measure(b, args.steps, work, args.variants)
            print(f"\n{b.spec} ({trajectory})")
            print(f"{'candidate':40} {'instructions/step':>18} {'Cortex-M4 .text B':>18}")
            for label, (per_step, size) in rows.items():
                print(f"{label:40} {per_step:18.2f} {size:18d}")
            gen, hand = list(rows.values())[:2]
            summary.append((b.spec, gen, hand))
    print(f"\n{'machine':24} {'instructions ratio':>20} {'.text ratio':>12}")
    for name, gen, hand in summary:
        print(f"{name:24} {gen[0] / hand[0]:20.3f} {gen[1] / hand[1]:12.3f}")
    print("target: both at most 1.3")
    if args.write_docs and not args.only:
        write_block("corpus", _table(summary), f"bench/bench_corpus_code.py --steps {args.steps} --write-docs")


def _table(summary: list[tuple[str, tuple[float, int], tuple[float, int]]]) -> list[str]:
    lines = [
        "| machine | generated instructions / step | hand-written | ratio | generated `.text` | hand-written | ratio |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, gen, hand in summary:
        lines.append(
            f"| `{name}` | {gen[0]:.2f} | {hand[0]:.2f} | **{gen[0] / hand[0]:.3f}** | {gen[1]:,} B | {hand[1]:,} B "
            f"| **{gen[1] / hand[1]:.3f}** |"
        )
    return lines


if __name__ == "__main__":
    main()
