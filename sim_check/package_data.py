"""Where the shipped specs and their generated code are: package data of sim_check (in a checkout, `shipped/`
holds links to spec/ and generated/), so a generated controller runs wherever the package is installed."""

from __future__ import annotations

from pathlib import Path

SHIPPED = Path(__file__).resolve().parent / "shipped"
SPECS = SHIPPED / "spec"
GENERATED = SHIPPED / "generated"
