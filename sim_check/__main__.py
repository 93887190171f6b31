"""`python -m sim_check` runs `mlca-sim`."""

from sim_check.cli import entry

entry()
