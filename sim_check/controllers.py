"""The generated controllers: the Python module or the C library (ctypes), one per AV state."""

from __future__ import annotations

import functools
import tempfile
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.codegen import machine_ir
from mlca_verify.conform.targets import CMachine, PyMachine, build_shared, load_python
from mlca_verify.errors import ToolError, UsageError
from mlca_verify.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
CONTROLLERS = ("mlca-py", "mlca-c", "mlca_r-py", "mlca_r-c")


@dataclass
class Controller:
    """A generated machine behind one interface: states are the generated enum's integers."""

    name: str
    states: tuple[str, ...]
    initial: int
    py: PyMachine | None = None
    c: CMachine | None = None

    def step(self, state: int, inputs: dict[str, bool]) -> int:
        return self.c.step(state, inputs) if self.c else self.py.step(state, inputs)  # type: ignore[union-attr]

    def failing(self, state: int, inputs: dict[str, bool]) -> list[str]:
        """The runtime monitor: failing invariant ids (the C monitor says only whether all hold)."""
        if self.c:
            return [] if self.c.invariants_hold(state, inputs) else ["invariants"]
        return self.py.invariants(state, inputs)  # type: ignore[union-attr]


@functools.cache
def load_controller(name: str, generated: Path = ROOT / "generated") -> Controller:
    """The controller, loaded (and for C, compiled) once per process."""
    if name not in CONTROLLERS:
        raise UsageError(f"error: unknown controller '{name}' (known: {', '.join(CONTROLLERS)})")
    machine, lang = name.rsplit("-", 1)
    spec = load_spec(ROOT / "spec" / f"{machine}.toml", compare=False)
    ir = machine_ir(spec, generated)
    initial = ir.states.index(ir.initial)
    if lang == "py":
        module = load_python(generated / "python" / f"{ir.module}_fsm.py", f"_sim_{ir.module}_fsm")
        return Controller(name, ir.states, initial, py=PyMachine(module))
    build = Path(tempfile.mkdtemp(prefix="mlca-sim-"))
    library = build / f"lib{ir.module}_fsm.so"
    ran = build_shared(generated / "c" / f"{ir.module}_fsm.c", library)
    if ran.returncode != 0:
        raise ToolError(f"error: cannot build the C controller: {ran.output.strip()}")
    return Controller(name, ir.states, initial, c=CMachine(library, ir))
