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
from typing import Any, Literal

from mlca_verify.codegen import machine_ir
from mlca_verify.errors import UsageError
from mlca_verify.layout import Layout
from mlca_verify.loading import CMachine, PythonMachine, build_c, flag_definitions, load_python
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
    folder: str = ""  # the spec's folder under SPECS

    @property
    def spec(self) -> Path:
        return SPECS / self.folder / f"{self.machine}.toml"


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


def _fsm(machine: str, language: Language, label: str, stands_for: str, folder: str = "") -> Setup:
    return Setup(f"{machine}-{language}", "fsm", label, stands_for, generated=Generated(machine, language, folder))


def _v2v(machine: str, language: Language, label: str, protocol: str) -> Setup:
    """A controller that talks to the other AVs: the generated machine of `spec/v2v/<machine>.toml`, each AV's
    claims sent through the scenario's radio (sim_check.radio)."""
    code = "Python" if language == "py" else "C"
    return _fsm(machine, language, label, f"MLCA-T with {protocol} (spec/v2v/{machine}.toml), generated {code}", "v2v")


# Sec. IV-C of the paper names its comparison models; Sec. II describes them (LC2013, LC2014, LC2017, MOBIL,
# IDM/LC, Continuous) and Fig. 6 adds "without algorithm".
SUBLANE_RESOLUTION_M = 3.2  # chosen by bench/bench_matrix.py --lateral (see docs/explanation/paper-comparison.md)
CLAIM_PROTOCOL = (
    "the repaired V2V protocol: an AV claims the gap for a few steps before it moves into it and gives way by "
    "priority; each AV runs its own instance, its claims sent through the scenario's radio"
)
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
        _v2v("mlca_t_v2v", "py", "MLCA-T V2V (Python)", "the first V2V protocol: move at once, claiming the gap"),
        _v2v("mlca_t_v2v", "c", "MLCA-T V2V", "the first V2V protocol: move at once, claiming the gap"),
        _v2v("mlca_t_claim", "py", "MLCA-T claim (Python)", CLAIM_PROTOCOL),
        _v2v("mlca_t_claim", "c", "MLCA-T claim", CLAIM_PROTOCOL),
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
V2V_CONTROLLERS = tuple(n for n, s in SETUPS.items() if s.generated and s.generated.folder == "v2v")
# The paper's comparison (Sec. IV): every model once, MLCA as generated C, the repairs, and MLCA-T with the repaired
# V2V protocol (the AVs of the paper's second scenario "in real-time communication", Sec. III-A).
PAPER_MATRIX = (
    "lc2013",
    "sl2015",
    "continuous",
    "idm-lc",
    "mobil",
    "without",
    "mlca-c",
    "mlca_r-c",
    "mlca_t-c",
    "mlca_t_claim-c",
)


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
    """A generated machine behind one interface: `context()` is a new context, `advance(context, *values)` one step
    and its runtime monitor, answered as (packed, *outputs) (see mlca_verify.loading.PythonMachine: the mode
    reached, HOLDS where every invariant holds after the step, the transition that fired, the boolean definitions
    `flags` as the step saw them); values are the boolean inputs `inputs`, then the signals `signals`, the order
    `values` puts an inputs dict in. `transitions` names the transitions by number from 1. The loop reads the side
    to move to from the output `command` (+1 left, -1 right, 0 none) at `command_at` among the outputs, or, where
    the machine has none (Alg. 1), from the mode."""

    name: str
    states: tuple[str, ...]
    initial: int
    inputs: tuple[str, ...]
    signals: tuple[str, ...]
    transitions: tuple[str, ...]
    flags: tuple[str, ...]
    command_at: int | None
    machine: PythonMachine | CMachine
    claims_at: tuple[int, ...] = ()  # a machine talking to the other AVs: its claims_left and claims_right outputs

    def __post_init__(self) -> None:
        self.context: Callable[..., Any] = self.machine.context
        self.advance: Callable[..., tuple[Any, ...]] = self.machine.advance
        self.values = input_values(self.inputs)

    def failing(self) -> list[str]:
        """The invariants that failed in the last step: by id from the Python machine; the C says only that one
        did."""
        return list(self.machine.failing)


# How the loop drives a machine: on the booleans sim_check.sensing derives (a need, can-wait, and a safe gap on
# each side), or on the need and its urgency with the raw gap and speed signals, the machine deciding the rest.
SENSED_INPUTS = ("N", "W", "L", "R")
SIGNAL_INPUTS = ("N", "U")
V2V_INPUTS = ("N", "heard_left", "heard_right", "U")  # ... and what the other AVs' claims say (sim_check.radio)
V2V_OUTPUTS = ("claims_left", "claims_right")


@functools.cache
def load_controller(name: str, generated: Path = GENERATED) -> Controller:
    """The generated machine of an `fsm` controller, loaded (and for C, compiled) once per process."""
    code = setup_of(name).generated
    if code is None:
        raise UsageError(f"error: controller '{name}' is not a generated machine")
    ir = machine_ir(load_spec(code.spec, compare=False), generated)
    signals, inputs = tuple(s.name for s in ir.signals), tuple(i.name for i in ir.inputs)
    outputs = tuple(o.name for o in ir.outputs)
    talks = inputs == V2V_INPUTS and set(V2V_OUTPUTS) <= set(outputs)
    drivable = (inputs == SENSED_INPUTS and not signals) or (
        inputs in (SIGNAL_INPUTS, V2V_INPUTS) and signals == SENSED and "command" in outputs
    )
    if not drivable or (inputs == V2V_INPUTS and not talks):
        raise UsageError(
            f"error: controller '{name}': the closed loop drives a machine whose inputs are {', '.join(SENSED_INPUTS)} "
            f"(no signals), or one whose inputs are {', '.join(SIGNAL_INPUTS)} (or, talking to the other AVs, "
            f"{', '.join(V2V_INPUTS)} with the outputs {' and '.join(V2V_OUTPUTS)}), whose signals are "
            f"{', '.join(SENSED)}, in that order, and which has an output 'command'"
        )
    layout, flags = Layout(generated, ir.module), flag_definitions(ir)
    if code.language == "py":
        machine: PythonMachine | CMachine = load_python(layout, f"_sim_{ir.module}", flags)
    else:
        with tempfile.TemporaryDirectory(prefix="mlca-sim-") as build:  # the loaded library outlives its files
            machine = build_c(layout, ir, Path(build), f"_{ir.module}_sim")
    transitions = tuple(tid for _, tid, _ in ir.transitions)
    command_at = outputs.index("command") if "command" in outputs else None
    claims_at = tuple(outputs.index(o) for o in V2V_OUTPUTS) if talks else ()
    initial = ir.states.index(ir.initial)
    return Controller(name, ir.states, initial, inputs, signals, transitions, flags, command_at, machine, claims_at)
