"""mlca-verify: formal verification and code generation for the MLCA lane-change state machine.

The public Python API (everything the CLI does, as functions):

    from pathlib import Path
    import mlca_verify as mv

    spec = mv.load_spec("spec/mlca_r.toml")                  # a LoadedSpec: path, sha256, machine
    results = mv.check_all(spec.machine)                     # one Result per property, with counterexamples
    files = mv.generate(spec, Path("generated"))             # relative path -> text
    mv.write(files, Path("generated"))
    report = mv.conform(spec, Path("generated"), ["compile", "exhaustive"], print)

Errors are `MlcaError`s (`SpecError` carries the file, line and column).
"""

from typing import TYPE_CHECKING

from mlca_verify.errors import CodegenError, MlcaError, SpecError, ToolError, UsageError
from mlca_verify.lazy import lazy_exports
from mlca_verify.version import __version__

if TYPE_CHECKING:
    from mlca_verify.codegen import drift, generate, write
    from mlca_verify.conformance import CHECKS, Conformance, conform
    from mlca_verify.layout import Layout
    from mlca_verify.loading import build_c, load_python
    from mlca_verify.logic import check_all, compare
    from mlca_verify.logic.results import Result
    from mlca_verify.model import Machine
    from mlca_verify.spec import LoadedSpec, load_spec, load_text

# Imported on first use, so that a command loads only what it runs (the code generator and the conformance
# checks pull in Jinja and Hypothesis, which `check` never needs).
_HOMES = {
    "drift": "mlca_verify.codegen",
    "generate": "mlca_verify.codegen",
    "write": "mlca_verify.codegen",
    "CHECKS": "mlca_verify.conformance",
    "Conformance": "mlca_verify.conformance",
    "conform": "mlca_verify.conformance",
    "check_all": "mlca_verify.logic",
    "compare": "mlca_verify.logic",
    "Result": "mlca_verify.logic.results",
    "Machine": "mlca_verify.model",
    "LoadedSpec": "mlca_verify.spec",
    "load_spec": "mlca_verify.spec",
    "load_text": "mlca_verify.spec",
    "Layout": "mlca_verify.layout",
    "build_c": "mlca_verify.loading",
    "load_python": "mlca_verify.loading",
}


__getattr__ = lazy_exports("mlca_verify", _HOMES)


__all__ = [
    "CHECKS",
    "CodegenError",
    "Conformance",
    "Layout",
    "LoadedSpec",
    "Machine",
    "MlcaError",
    "Result",
    "SpecError",
    "ToolError",
    "UsageError",
    "__version__",
    "build_c",
    "check_all",
    "compare",
    "conform",
    "drift",
    "generate",
    "load_python",
    "load_spec",
    "load_text",
    "write",
]
