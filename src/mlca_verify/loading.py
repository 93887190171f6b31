"""How generated code is loaded: imported, or built and imported, behind two calls.

Every consumer (conform, emit, evidence, the closed loop) finds a machine's files through `layout.Layout`; the
closed loop runs them through `context()` (a new context) and `advance(context, *values)` (one step and the
monitor, answered as one packed int and the outputs), which the Python module and the C extension both answer.

Python is imported from its file; C is built with the interpreter's headers into an extension module whose
functions the interpreter calls directly (METH_FASTCALL). That is the closed loop's fast path: measured with
`bench/bench_sim.py --instructions 500`, a step through ctypes and libffi cost several times the instructions
of this call, and the code and data they touch between two SUMO steps evicted part of SUMO's from the cache.
"""

from __future__ import annotations

import importlib.util
import sys
import sysconfig
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import Any

from mlca_verify.codegen.ir import MachineIR
from mlca_verify.codegen.render import render_template
from mlca_verify.errors import ToolError
from mlca_verify.layout import Layout
from mlca_verify.tools import build_shared

HOLDS = 0x10000  # the bit of an `advance` answer that says every invariant holds in the state reached
STATE_BITS = 0xFFFF  # the bits of an `advance` answer that are the state reached
FIRED_SHIFT = 20  # the answer holds the number of the transition that fired, plus one, here
FIRED_MASK = 0xFFF  # ... in these bits (after the shift)
DEFS_SHIFT = 32  # ... and from here, one bit per boolean definition (`flag_definitions`), as the step saw it


def fired_in(packed: int) -> int:
    """The number of the transition an answer says fired, from 1 (0: none, or the mode was not a state)."""
    return max(0, ((packed >> FIRED_SHIFT) & FIRED_MASK) - 1)


def flag_definitions(ir: MachineIR) -> tuple[str, ...]:
    """The boolean definitions the generated code computes (L, R, W of MLCA-T), in the spec's order: an `advance`
    answer holds their values, as the step saw them, from DEFS_SHIFT on."""
    flags = tuple(d.name for d in ir.definitions if d.ctype == "bool" and d.name in ir.used)
    if len(flags) > 31 or len(ir.transitions) + 1 > FIRED_MASK:
        raise ToolError(
            f"error: {ir.module} has {len(flags)} boolean definitions and {len(ir.transitions)} transitions; the "
            f"closed loop's one-call answer holds at most 31 and {FIRED_MASK - 1}"
        )
    return flags


class Watched:
    """A context of the generated Python, the observers its monitor keeps beside it (the variables only invariants
    read, see `MachineIR.observers`; None where it keeps none) and the params it runs with, as one context of
    `PythonMachine`; `mode` is the context's."""

    def __init__(self, ctx: Any, observers: Any, params: Any) -> None:
        self.ctx = ctx
        self.observers = observers
        self.params = params

    @property
    def mode(self) -> Any:
        return self.ctx.mode

    @mode.setter
    def mode(self, value: Any) -> None:
        self.ctx.mode = value


class PythonMachine:
    """The generated Python of a machine, behind the same two calls as its C extension module: `context()`
    is a new context, and `advance(context, *values)` one step and the monitor, in place, answered as
    (packed, *outputs): the mode reached, HOLDS where every invariant holds after the step, the number of the
    transition that fired plus one, shifted left by FIRED_SHIFT (0 where the mode was not a state), and the values
    of `flags` (the boolean definitions) in the context before the step, from DEFS_SHIFT on. Values are the inputs'
    and then the signals', in declared order; the params are the spec's defaults, but for those `context` is given.
    `failing` names the invariants that failed in the last step."""

    def __init__(self, module: ModuleType, flags: Sequence[str]) -> None:
        self.module = module
        self.flags = tuple(getattr(module, f"_def_{name}") for name in flags)
        self.failing: list[str] = []

    def context(self, params: Mapping[str, float | int] | None = None) -> Watched:
        """A new context that runs with the spec's params but `params` (by name; each within its range)."""
        m = self.module
        chosen = replace(m.DEFAULT_PARAMS, **params) if params else m.DEFAULT_PARAMS
        if not chosen.valid():
            raise ToolError(f"error: params {dict(params or {})} lie outside their ranges")
        return Watched(m.Context(), m.Observers() if hasattr(m, "Observers") else None, chosen)

    def advance(self, ctx: Watched, *values: Any) -> tuple[Any, ...]:
        m = self.module
        seen = () if ctx.observers is None else (ctx.observers,)
        inputs, params = m.Inputs(*values), ctx.params
        ctx = ctx.ctx
        before = m.Context(**vars(ctx))
        fired = m._fired(before, inputs, params)
        out = m.step(ctx, inputs, params)
        self.failing = m.monitor(before, ctx, inputs, params, out, *seen)
        packed = int(ctx.mode) | (fired + 1) << FIRED_SHIFT | (0 if self.failing else HOLDS)
        for k, flag in enumerate(self.flags):
            if flag(before, inputs, params):
                packed |= 1 << (DEFS_SHIFT + k)
        return (packed, *vars(out).values())


class CMachine:
    """The generated C of a machine, built with a small adapter into an extension module: the same
    calls as PythonMachine (the context is a bytearray); its monitor says only that an invariant failed."""

    def __init__(self, extension: ModuleType, params: Sequence[str] = ()) -> None:
        self.extension = extension
        self.advance = extension.advance
        self.params = tuple(params)  # the params' names, in the spec's order (`set_param`'s indices)
        self.failing = ["invariants"]

    def context(self, params: Mapping[str, float | int] | None = None) -> bytearray:
        """A new context that runs with the spec's params but `params` (by name; each within its range)."""
        ctx: bytearray = self.extension.context()
        for name, value in (params or {}).items():
            if name not in self.params:
                raise ToolError(f"error: no param {name!r} (the params: {', '.join(self.params) or 'none'})")
            try:
                self.extension.set_param(ctx, self.params.index(name), value)
            except ValueError:
                raise ToolError(f"error: param {name} = {value} lies outside its range") from None
        return ctx


def load_python(layout: Layout, name: str, flags: Sequence[str] = ()) -> PythonMachine:
    """Import the generated Python of `layout` as the module `name`, behind `context()` and `advance()`; `flags`
    names the boolean definitions whose values each answer carries (see `flag_definitions`)."""
    return PythonMachine(import_generated(layout.python, name), flags)


def import_generated(path: Path, name: str) -> ModuleType:
    """Import a generated Python file as the module `name`."""
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ToolError.at(path, "cannot import generated module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def python_headers() -> Path:
    """The folder of this interpreter's Python.h, which the C machine's adapter is built against."""
    folder = Path(sysconfig.get_paths()["include"])
    if not (folder / "Python.h").is_file():
        raise ToolError(
            f"error: cannot build the generated C for Python: no Python.h in {folder}; install this Python's "
            "development headers (Debian: python3-dev), as scripts/setup.sh does"
        )
    return folder


def build_c(layout: Layout, ir: MachineIR, build: Path, name: str) -> CMachine:
    """Build the generated C of the machine of `layout` with its adapter into `build` and import it as
    the module `name`; the adapter includes the generated source, which is compiled once, with it."""
    given = {
        "m": ir,
        "extension": name,
        "holds": hex(HOLDS),
        "fired_shift": FIRED_SHIFT,
        "defs_shift": DEFS_SHIFT,
        "flags": flag_definitions(ir),
    }
    python_side, machine_side = build / f"{name}.c", build / f"{ir.module}_ext_bits.c"
    python_side.write_text(render_template("extension.c.j2", **given), encoding="utf-8")
    machine_side.write_text(render_template("extension_bits.c.j2", **given), encoding="utf-8")
    library = build / f"{name}.so"
    include = ("-ffp-contract=off", "-I", str(layout.c_source.parent), "-I", str(python_headers()), str(python_side))
    ran = build_shared(machine_side, library, include)
    if ran.returncode != 0:
        raise ToolError(f"error: cannot build the generated C of {layout.module}: {_first_error(ran.output)}")
    return CMachine(import_extension(library, name), [f.name for f in ir.params])


def _first_error(output: str) -> str:
    """The compiler's first error line (the one that says what is wrong), or its first line."""
    lines = output.strip().splitlines()
    return next((line for line in lines if "error:" in line), lines[0] if lines else "no output")


def import_extension(library: Path, name: str) -> ModuleType:
    """Import the extension module `name` from the shared library `library`."""
    spec = importlib.util.spec_from_file_location(name, library)
    if spec is None or spec.loader is None:
        raise ToolError(f"error: cannot load the generated C from {library}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
