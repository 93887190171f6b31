"""The closed loop's scenarios: the scenario file's errors and defaults, and a road imported from OpenStreetMap."""

from __future__ import annotations

from pathlib import Path

import pytest

from mlca_verify.errors import SpecError
from sim_check.runner import run_once
from sim_check.scenario import load_scenario
from tests.conftest import ROOT


def test_scenario_errors_name_the_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[road]\nlanes = 5\nlenght_m = 3\n")
    with pytest.raises(SpecError, match=r"bad.toml:3:12: error: unknown key 'lenght_m' in \[road\]"):
        load_scenario(bad)
    bad.write_text("[traffic]\ncars = -4\n")
    with pytest.raises(SpecError, match=r"bad.toml:2:8: error: 'cars' in \[traffic\] must be positive"):
        load_scenario(bad)


def test_paper_defaults() -> None:
    s = load_scenario()
    assert (s.road.lanes, s.road.highway_speed_kmh, s.traffic.cars, s.target_lane) == (5, 80, 100, 2)


def test_openstreetmap_road_is_imported_and_driven(tmp_path: Path) -> None:
    scenario_file = tmp_path / "osm.toml"
    osm = ROOT / "tests" / "fixtures" / "small.osm"
    scenario_file.write_text(
        f'[road]\nosm = "{osm}"\nroute = "100 101"\nlanes = 3\n\n[traffic]\ncars = 10\navs = 1\ndepart_window_s = 20\nneed = "middle"\n'
    )
    result = run_once(load_scenario(scenario_file), "mlca_r-c", 3, tmp_path / "work")
    assert result.status == "done" and result.violations == []
    av = result.metrics[0].row()
    assert av["arrived"] and av["lc_5km"] == 1  # from lane 0 into the middle lane of the three
    assert 1900 < result.metrics[0].distance_m < 2100


def test_openstreetmap_road_needs_a_route(tmp_path: Path) -> None:
    scenario_file = tmp_path / "osm.toml"
    scenario_file.write_text(f'[road]\nosm = "{ROOT / "tests" / "fixtures" / "small.osm"}"\n')
    with pytest.raises(SpecError, match=r"osm\.toml:2:7: error: an OpenStreetMap road needs 'route'"):
        load_scenario(scenario_file)
