#!/usr/bin/env bash
# Set up, then run the main job on the shipped specs: prove every property of the canonical machine, the
# repaired machine and the paper's two other readings, and write the JSON report to out/check.json.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mkdir -p out
.venv/bin/mlca-verify check spec/mlca.toml spec/mlca_r.toml spec/paper/*.toml --json out/check.json
echo "main: results written to out/check.json"
