"""SUMO's SSM device (surrogate safety measures) for the AVs: its options, and its output file read back per AV.

The device logs a conflict where a measure passes its threshold (SUMO's defaults: TTC below 3 s, DRAC above
3 m/s², PET below 2 s) with another vehicle within 50 m in the same or a crossing lane; it does not see vehicles in
the neighbouring lanes (sumo-facts.md), so the lane changes' own gaps are measured apart (sim_check.runner).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

MEASURES = "TTC DRAC PET"


def options(av_ids: tuple[str, ...], output: Path) -> tuple[str, ...]:
    """SUMO's options that give each AV an SSM device writing into `output`."""
    return (
        "--device.ssm.explicit",
        ",".join(av_ids),
        "--device.ssm.measures",
        MEASURES,
        "--device.ssm.file",
        str(output),
    )


@dataclass
class Conflicts:
    """One AV's conflicts as the device logged them: their number, the smallest TTC and PET (s) and the largest
    DRAC (m/s²) among them (None where none was logged)."""

    count: int = 0
    min_ttc_s: float | None = None
    max_drac: float | None = None
    min_pet_s: float | None = None


def _value(element: ET.Element | None) -> float | None:
    """A measure's value ("NA" or absent: none)."""
    text = element.get("value") if element is not None else None
    try:
        value = float(text) if text is not None else math.nan
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _fold(current: float | None, new: float | None, pick: Callable[[float, float], float]) -> float | None:
    return new if current is None else current if new is None else pick(current, new)


def read(output: Path, av_ids: tuple[str, ...]) -> dict[str, Conflicts]:
    """Each AV's conflicts from the device's file (an AV with none has a zero count)."""
    found = {av: Conflicts() for av in av_ids}
    if not output.exists():
        return found
    for _, element in ET.iterparse(output):
        if element.tag != "conflict":
            continue
        ego = found.get(element.get("ego", ""))
        if ego is not None:
            ego.count += 1
            ego.min_ttc_s = _fold(ego.min_ttc_s, _value(element.find("minTTC")), min)
            ego.max_drac = _fold(ego.max_drac, _value(element.find("maxDRAC")), max)
            ego.min_pet_s = _fold(ego.min_pet_s, _value(element.find("PET")), min)
        element.clear()
    return found
