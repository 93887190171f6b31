"""The controllers an AV can have: the generated MLCA machines (Python module, or C built as a shared library that
Python imports) and the
paper's comparison models, each described by a `Setup` (what drives the AV and what SUMO is told).

SUMO ships the lane-change models LC2013, SL2015 and DK2008, and nothing named LC2014, LC2017 or MOBIL; the
`stands_for` of each setup says which SUMO model or implementation stands in for a name of the paper and why."""

from __future__ import annotations

import functools
import itertools
import operator
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mlca_verify.codegen import data_ir, machine_ir
from mlca_verify.errors import UsageError
from mlca_verify.layout import Layout
from mlca_verify.loading import (
    HOLDS,
    STATE_BITS,
    DataCMachine,
    DataPythonMachine,
    PythonMachine,
    build_c,
    build_data_c,
    flag_definitions,
    import_generated,
    load_python,
)
from mlca_verify.model import Machine, evaluate
from mlca_verify.spec import load_spec
from sim_check.package_data import GENERATED, SPECS
from sim_check.signals import SENSED

Kind = Literal["fsm", "sumo", "mobil", "without"]
Language = Literal["py", "c"]


@dataclass(frozen=True)
class Generated:
    """The code a generated controller runs: the machine of the shipped spec `SPECS/<machine>.toml`, in one
    language."""

    machine: str
    language: Language

    @property
    def spec(self) -> Path:
        return SPECS / f"{self.machine}.toml"


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
    generated: Generated | None = None  # what a `fsm` controller runs


def _fsm(machine: str, language: Language, label: str, stands_for: str) -> Setup:
    return Setup(f"{machine}-{language}", "fsm", label, stands_for, generated=Generated(machine, language))


# Sec. IV-C of the paper names its comparison models; Sec. II describes them (LC2013, LC2014, LC2017, MOBIL,
# IDM/LC, Continuous) and Fig. 6 adds "without algorithm".
SUBLANE_RESOLUTION_M = 3.2  # chosen by bench/bench_matrix.py --lateral (see the README)
SETUPS = {
    s.name: s
    for s in (
        _fsm("mlca", "py", "MLCA (Python)", "MLCA, Alg. 1: the generated Python code"),
        _fsm("mlca", "c", "MLCA", "MLCA, Alg. 1: the generated C code"),
        _fsm("mlca_r", "py", "MLCA-R (Python)", "the repaired machine (docs/findings.md F1), generated Python"),
        _fsm("mlca_r", "c", "MLCA-R", "the repaired machine (docs/findings.md F1), generated C"),
        _fsm(
            "mlca_t",
            "py",
            "MLCA-T (Python)",
            "MLCA-T: the whole decision function of spec/mlca_t.toml (waiting timer, RSS gap rule), generated Python",
        ),
        _fsm(
            "mlca_t",
            "c",
            "MLCA-T",
            "MLCA-T: the whole decision function of spec/mlca_t.toml (waiting timer, RSS gap rule), generated C",
        ),
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
PAPER_MATRIX = ("lc2013", "sl2015", "continuous", "idm-lc", "mobil", "without", "mlca-c", "mlca_r-c", "mlca_t-c")


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
    or to the Python machine, so that a step costs the loop one call). `transitions` names the spec's transitions
    by number from 1, and `fired` says which one fires from a state with the inputs' values (absent: none), by the
    spec's own semantics (mlca_verify.model), not the generated code's."""

    name: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    initial: int
    packed: Callable[..., int]
    transitions: tuple[str, ...] = ()
    fired: dict[tuple[int, tuple[bool, ...]], int] = field(default_factory=dict)
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


@dataclass
class DataController:
    """A generated machine with data (its whole decision function) behind one interface: `context()` is a new
    context, `advance(context, *values)` one step and its monitor, answered as (packed, *outputs) (see
    mlca_verify.loading.DataPythonMachine); values are the boolean inputs `inputs`, then the signals `signals`.
    `transitions` names the transitions by number from 1, `flags` the boolean definitions whose values the answer
    holds, and `command_at` the place of the output `command` (+1 left, -1 right, 0 none) among the outputs."""

    name: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    signals: tuple[str, ...]
    transitions: tuple[str, ...]
    flags: tuple[str, ...]
    command_at: int
    machine: DataPythonMachine | DataCMachine

    def __post_init__(self) -> None:
        self.context: Callable[[], Any] = self.machine.context
        self.advance: Callable[..., tuple[Any, ...]] = self.machine.advance

    def failing(self) -> list[str]:
        """The invariants that failed in the last step: by id from the Python machine; the C says only that one
        did."""
        return list(self.machine.failing)


@functools.cache
def load_controller(name: str, generated: Path = GENERATED) -> Controller | DataController:
    """The generated machine of an `fsm` controller, loaded (and for C, compiled) once per process."""
    code = setup_of(name).generated
    if code is None:
        raise UsageError(f"error: controller '{name}' is not a generated machine")
    lang = code.language
    spec = load_spec(code.spec, compare=False)
    if spec.machine.has_data:
        return _load_data(name, spec, lang, generated)
    ir = machine_ir(spec, generated)
    layout = Layout(generated, ir.module)
    initial, names = ir.states.index(ir.initial), tuple(i.name for i in ir.inputs)
    if lang == "py":
        py = load_python(layout, names, f"_sim_{ir.module}_fsm")
        return Controller(name, ir.states, names, initial, py.advance, *_fired_table(spec.machine, ir.states), py=py)
    with tempfile.TemporaryDirectory(prefix="mlca-sim-") as build:  # the loaded library outlives its files
        c = build_c(layout, ir, Path(build), f"_{ir.module}_sim")
    return Controller(name, ir.states, names, initial, c.advance, *_fired_table(spec.machine, ir.states))


def _fired_table(
    machine: Machine, states: tuple[str, ...]
) -> tuple[tuple[str, ...], dict[tuple[int, tuple[bool, ...]], int]]:
    """The transitions of a boolean machine with first-match semantics, and the one that fires (by number from 1)
    from each state under each valuation of the inputs."""
    names, table = machine.input_names, {}
    for k, state in enumerate(states):
        for values in itertools.product((False, True), repeat=len(names)):
            given = dict(zip(names, values, strict=True))
            for number, t in enumerate(machine.transitions, 1):
                if t.applies_to(state) and evaluate(t.guard, given, state):
                    table[(k, values)] = number
                    break
    return tuple(t.id for t in machine.transitions), table


def _load_data(name: str, spec: Any, lang: str, generated: Path) -> DataController:
    ir = data_ir(spec, generated)
    signals, inputs = tuple(s.name for s in ir.signals), tuple(i.name for i in ir.inputs)
    outputs = tuple(o.name for o in ir.outputs)
    if signals != SENSED or inputs != ("N", "U") or "command" not in outputs:
        raise UsageError(
            f"error: controller '{name}': the closed loop drives a machine whose inputs are N, U, whose signals are "
            f"{', '.join(SENSED)}, in that order, and which has an output 'command'"
        )
    layout, flags = Layout(generated, ir.module), flag_definitions(ir)
    if lang == "py":
        machine: DataPythonMachine | DataCMachine = DataPythonMachine(
            import_generated(layout.python, f"_sim_{ir.module}_data"), flags
        )
    else:
        with tempfile.TemporaryDirectory(prefix="mlca-sim-") as build:  # the loaded library outlives its files
            machine = build_data_c(layout, ir, Path(build), f"_{ir.module}_sim")
    transitions = tuple(tid for _, tid, _ in ir.transitions)
    return DataController(name, ir.states, inputs, signals, transitions, flags, outputs.index("command"), machine)
