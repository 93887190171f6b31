#!/usr/bin/env bash
# Set up, then run the whole test suite: lint (ruff), types (mypy, strict on src/), the drift check of the
# generated code, and every test (pytest), slow ones included.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/ruff check src sim_check tests bench scripts
.venv/bin/ruff format --check src sim_check tests bench scripts
.venv/bin/mypy
.venv/bin/mlca-verify gen --check
.venv/bin/pytest -n 2 --dist loadgroup "$@"
