"""The closed loop's scenarios: the scenario file's errors and defaults, and a road imported from OpenStreetMap."""

from __future__ import annotations

from pathlib import Path

import pytest

from mlca_verify.errors import SpecError
from sim_check.runner import run_once
from sim_check.scenario import build, load_scenario
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


def test_arrival_lane_is_given_to_the_avs_alone(tmp_path: Path) -> None:
    exit_file = ROOT / "sim_check" / "scenarios" / "exit.toml"
    scenario = load_scenario(exit_file)
    assert (scenario.arrival_lane, load_scenario().arrival_lane) == (0, None)
    routes = build(scenario.with_avs(3), 1, tmp_path).routes.read_text().splitlines()
    avs = [line for line in routes if 'type="av"' in line]
    assert len(avs) == 3 and all('arrivalLane="0"' in line for line in avs)
    assert sum("arrivalLane" in line for line in routes) == 3  # the background cars leave from any lane
    middle = tmp_path / "middle.toml"
    middle.write_text('[traffic]\nav_arrival_lane = "middle"\n')
    assert load_scenario(middle).arrival_lane == 2


def test_the_exit_makes_mlca_t_urgent_right_and_right_abort_fire(tmp_path: Path) -> None:
    """On the paper's road neither can fire (no urgent wish to the right); an exit in the rightmost lane makes SUMO's
    model want the right urgently near the end, and moves of more than one lane to the right."""
    scenario = load_scenario(ROOT / "sim_check" / "scenarios" / "exit.toml").with_avs(3)
    result = run_once(scenario, "mlca_t-c", 4, tmp_path)
    assert result.status == "done" and result.violations == []
    fired = {t: sum(m.transitions.get(t, 0) for m in result.metrics) for t in ("urgent_right", "right_abort")}
    assert fired["urgent_right"] >= 1 and fired["right_abort"] >= 1
    assert any(e.urgent and e.side == -1 for m in result.metrics for e in m.episodes)
    plain_road = run_once(load_scenario().with_avs(3), "mlca_t-c", 4, tmp_path / "paper")
    assert not any(e.urgent and e.side == -1 for m in plain_road.metrics for e in m.episodes)
    assert sum(m.transitions.get("urgent_right", 0) for m in plain_road.metrics) == 0


def test_openstreetmap_road_takes_no_arrival_lane(tmp_path: Path) -> None:
    scenario_file = tmp_path / "osm.toml"
    osm = ROOT / "tests" / "fixtures" / "small.osm"
    scenario_file.write_text(f'[road]\nosm = "{osm}"\nroute = "100"\n[traffic]\nav_arrival_lane = 0\n')
    with pytest.raises(SpecError, match=r"osm\.toml:5:19: error: 'av_arrival_lane' is for the built-in highway"):
        load_scenario(scenario_file)
