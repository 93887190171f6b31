"""mlca-verify: formal verification and code generation for the MLCA lane-change state machine."""

__version__ = "0.1.0"
