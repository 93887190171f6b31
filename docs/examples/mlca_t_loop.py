"""A Python loop around the generated MLCA-T decision function (generated/python/mlca_t_fsm.py): the same
function as the C, bit for bit. Run from the repository: `.venv/bin/python docs/examples/mlca_t_loop.py`."""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "generated" / "python"))

import mlca_t_fsm as mlca_t  # the generated module, found on the path set above


def sense(tick: int) -> mlca_t.Inputs:
    """One sample of every input; the left follower's speed sensor fails at tick 30 (NaN)."""
    return mlca_t.Inputs(
        N=tick >= 5,
        U=False,
        v=25.0,
        gap_lead_left=1000.0,
        gap_follow_left=110.0,  # RSS asks for 106.1 m from a follower at 27 m/s behind the AV at 25 m/s
        v_follow_left=math.nan if tick == 30 else 27.0,
        v_lead_left=0.0,
        gap_lead_right=1000.0,
        gap_follow_right=1000.0,
        v_follow_right=0.0,
        v_lead_right=0.0,
    )


def main() -> None:
    ctx = mlca_t.Context()
    for tick in range(40):
        out = mlca_t.step(ctx, sense(tick), mlca_t.DEFAULT_PARAMS)
        if tick in (4, 25, 26, 30, 31):
            print(f"tick {tick:2}: {mlca_t.State(ctx.mode).name:12} command {out.command:+d}")


if __name__ == "__main__":
    main()
