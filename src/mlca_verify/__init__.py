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

__version__ = "0.1.0"

from mlca_verify.codegen import drift, generate, write
from mlca_verify.conform import CHECKS, Conformance, conform
from mlca_verify.errors import CodegenError, MlcaError, SpecError, ToolError, UsageError
from mlca_verify.logic import check_all, compare
from mlca_verify.logic.results import Result
from mlca_verify.model import Machine
from mlca_verify.spec import LoadedSpec, load_spec, load_text
from mlca_verify.targets import Layout, build_c, load_python

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
