"""The controllers an AV can have: the generated MLCA machines (Python module, or C built as a shared library that
Python imports) and the
paper's comparison models, each described by a `Setup` (what drives the AV and what SUMO is told).

SUMO ships the lane-change models LC2013, SL2015 and DK2008, and nothing named LC2014, LC2017 or MOBIL; the
`stands_for` of each setup says which SUMO model or implementation stands in for a name of the paper and why."""

from __future__ import annotations

import functools
import operator
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from mlca_verify.codegen import machine_ir
from mlca_verify.errors import UsageError
from mlca_verify.spec import load_spec
from mlca_verify.targets import HOLDS, STATE_BITS, Layout, PythonMachine, build_c, load_python

ROOT = Path(__file__).resolve().parent.parent
Kind = Literal["fsm", "sumo", "mobil", "without"]


@dataclass(frozen=True)
class Setup:
    """One controller of the harness.

    kind: `fsm` (a generated machine decides, SUMO's lane changing off for the AV), `sumo` (SUMO's own lane-change
    model decides), `mobil` (sim_check.mobil decides, SUMO's lane changing off), `without` (the AV changes lane
    whenever N holds, with no gap check, SUMO's lane changing off).
    av_type: extra vType attributes of the AVs; options: extra SUMO options (they apply to every vehicle)."""

    name: str
    kind: Kind
    label: str
    stands_for: str
    av_type: str = ""
    options: tuple[str, ...] = ()


# Sec. IV-C of the paper names its comparison models; Sec. II describes them (LC2013, LC2014, LC2017, MOBIL,
# IDM/LC, Continuous) and Fig. 6 adds "without algorithm".
SUBLANE_RESOLUTION_M = 3.2  # chosen by bench/bench_matrix.py --lateral (see the README)
SETUPS = {
    s.name: s
    for s in (
        Setup("mlca-py", "fsm", "MLCA (Python)", "MLCA, Alg. 1: the generated Python code"),
        Setup("mlca-c", "fsm", "MLCA", "MLCA, Alg. 1: the generated C code"),
        Setup("mlca_r-py", "fsm", "MLCA-R (Python)", "the repaired machine (docs/findings.md F1), generated Python"),
        Setup("mlca_r-c", "fsm", "MLCA-R", "the repaired machine (docs/findings.md F1), generated C"),
        Setup(
            "lc2013",
            "sumo",
            "LC2013",
            "LC2013 and LC2014: SUMO's LC2013 (Erdmann's 2014 description of SUMO's "
            "lane-changing model is LC2013; SUMO has no model named LC2014)",
        ),
        Setup(
            "sl2015",
            "sumo",
            "LC2017 (SL2015)",
            "LC2017 and Continuous (sublane): SUMO's SL2015 sublane model, its newest lane-change model, which "
            "weighs several leaders and followers across sublanes as the paper's LC2017 description says (SUMO has "
            "no model named LC2017); the lateral resolution is a simulation option, so every vehicle drives SL2015",
            av_type='laneChangeModel="SL2015"',
            options=("--lateral-resolution", str(SUBLANE_RESOLUTION_M)),
        ),
        Setup(
            "continuous",
            "sumo",
            "Continuous",
            "Continuous: LC2013 with SUMO's continuous (non-instant, 3 s) lane changing, --lanechange.duration 3; "
            "a simulation option, so every vehicle changes lanes this way",
            options=("--lanechange.duration", "3"),
        ),
        Setup(
            "idm-lc",
            "sumo",
            "IDM/LC",
            "IDM/LC: IDM car following with SUMO's LC2013 for the AV",
            av_type='carFollowModel="IDM"',
        ),
        Setup(
            "dk2008",
            "sumo",
            "DK2008",
            "SUMO's oldest shipped lane-change model, for reference",
            av_type='laneChangeModel="DK2008"',
        ),
        Setup("mobil", "mobil", "MOBIL", "MOBIL (Kesting, Treiber and Helbing 2007), implemented in sim_check.mobil"),
        Setup(
            "without",
            "without",
            "Without",
            "without algorithm: the AV changes lane whenever N holds, with no gap check (laneChangeMode 0)",
        ),
    )
}
CONTROLLERS = tuple(SETUPS)
# The paper's comparison (Sec. IV): every model once, MLCA as generated C, and the repair.
PAPER_MATRIX = ("lc2013", "sl2015", "continuous", "idm-lc", "mobil", "without", "mlca-c", "mlca_r-c")


def setup_of(name: str) -> Setup:
    if name not in SETUPS:
        raise UsageError(f"error: unknown controller '{name}' (known: {', '.join(CONTROLLERS)})")
    return SETUPS[name]


def input_values(names: tuple[str, ...]) -> Callable[[dict[str, bool]], tuple[bool, ...]]:
    """A function from an inputs dict to its values in the order of `names` (one C call where there are two or
    more)."""
    if len(names) > 1:
        return operator.itemgetter(*names)
    return lambda inputs: tuple(inputs[n] for n in names)


@dataclass
class Controller:
    """A generated machine behind one interface: states are the generated enum's integers. `packed` is one step of
    the machine and its runtime monitor, called as packed(state, *values) with the inputs' values in the order of
    `inputs`: the state reached, with HOLDS set where every invariant holds there (bound at load to the C adapter
    or to the Python machine, so that a step costs the loop one call)."""

    name: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    initial: int
    packed: Callable[..., int]
    py: PythonMachine | None = None

    def __post_init__(self) -> None:
        self.values = input_values(self.inputs)

    def advance(self, state: int, inputs: dict[str, bool]) -> tuple[int, bool]:
        """The state reached from `state` with `inputs`, and whether every invariant holds there."""
        answer = self.packed(state, *self.values(inputs))
        return answer & STATE_BITS, bool(answer & HOLDS)

    def failing(self, state: int, inputs: dict[str, bool]) -> list[str]:
        """The invariants failing in `state`, reached with `inputs`, where the monitor said one fails: by id from
        the Python machine; the C monitor says only that one does."""
        return self.py.failing(state, self.values(inputs)) if self.py else ["invariants"]


@functools.cache
def load_controller(name: str, generated: Path = ROOT / "generated") -> Controller:
    """The generated machine of an `fsm` controller, loaded (and for C, compiled) once per process."""
    if setup_of(name).kind != "fsm":
        raise UsageError(f"error: controller '{name}' is not a generated machine")
    machine, lang = name.rsplit("-", 1)
    spec = load_spec(ROOT / "spec" / f"{machine}.toml", compare=False)
    ir = machine_ir(spec, generated)
    layout = Layout(generated, ir.module)
    initial, names = ir.states.index(ir.initial), tuple(i.name for i in ir.inputs)
    if lang == "py":
        py = load_python(layout, names, f"_sim_{ir.module}_fsm")
        return Controller(name, ir.states, names, initial, py.advance, py=py)
    with tempfile.TemporaryDirectory(prefix="mlca-sim-") as build:  # the loaded library outlives its files
        c = build_c(layout, ir, Path(build), f"_{ir.module}_sim")
    return Controller(name, ir.states, names, initial, c.advance)
