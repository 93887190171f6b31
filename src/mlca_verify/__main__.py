"""`python -m mlca_verify` runs the CLI."""

from mlca_verify.cli import entry

entry()
