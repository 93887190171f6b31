"""The generated code under test: the Python module imported from its file, the C code built and loaded."""

from __future__ import annotations

import ctypes
import importlib.util
import itertools
import sys
from pathlib import Path
from types import ModuleType

from mlca_verify.codegen.ir import MachineIR
from mlca_verify.conform.tools import C_FLAGS, Ran, run
from mlca_verify.errors import ToolError


def valuations(names: tuple[str, ...]) -> list[dict[str, bool]]:
    return [dict(zip(names, bits, strict=True)) for bits in itertools.product([False, True], repeat=len(names))]


def load_python(path: Path, name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ToolError(f"{path}: error: cannot import generated module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


class PyMachine:
    def __init__(self, module: ModuleType) -> None:
        self.module = module

    def step(self, state: int, inputs: dict[str, bool]) -> int:
        return int(self.module.step(state, self.module.Inputs(**inputs)))

    def invariants(self, state: int, inputs: dict[str, bool]) -> list[str]:
        return list(self.module.check_invariants(self.module.Inputs(**inputs), state))


def build_shared(c_file: Path, out: Path, extra: tuple[str, ...] = ()) -> Ran:
    return run(["gcc", *C_FLAGS, *extra, "-O2", "-shared", "-fPIC", "-o", str(out), str(c_file)], timeout=120)


class CMachine:
    """The generated C, loaded with ctypes: the inputs struct is rebuilt field by field from the IR."""

    def __init__(self, library: Path, ir: MachineIR) -> None:
        self.lib = ctypes.CDLL(str(library))
        fields = [(i.name, ctypes.c_bool) for i in ir.inputs]
        self.Inputs = type("Inputs", (ctypes.Structure,), {"_fields_": fields})
        self._step = getattr(self.lib, f"{ir.module}_step")
        self._step.argtypes = [ctypes.c_int, self.Inputs]
        self._step.restype = ctypes.c_int
        self._hold = getattr(self.lib, f"{ir.module}_invariants_hold")
        self._hold.argtypes = [self.Inputs, ctypes.c_int]
        self._hold.restype = ctypes.c_bool

    def step(self, state: int, inputs: dict[str, bool]) -> int:
        return int(self._step(state, self.Inputs(**inputs)))

    def invariants_hold(self, state: int, inputs: dict[str, bool]) -> bool:
        return bool(self._hold(self.Inputs(**inputs), state))
