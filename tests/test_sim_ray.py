"""Sweeps on a Ray cluster: the rows a local sweep gives, and an unreachable cluster is a usage error."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sim_check.cli import main
from tests.conftest import ROOT
from tests.sim_helpers import SHORT, rows


@pytest.fixture(scope="module")
def ray_cluster() -> str:
    """A local Ray cluster, started for these tests and stopped after them."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ray = str(Path(sys.executable).with_name("ray"))
    # Ray's default temp dir: a pytest tmp path is too long for the Unix sockets Ray creates under it
    start = [
        ray,
        "start",
        "--head",
        f"--port={port}",
        "--num-cpus=2",
        "--include-dashboard=false",
        "--disable-usage-stats",
    ]
    subprocess.run(start, check=True, capture_output=True, cwd=ROOT)
    yield f"127.0.0.1:{port}"  # type: ignore[misc]
    subprocess.run([ray, "stop", "--force"], check=False, capture_output=True)


@pytest.mark.slow
def test_sweep_on_a_ray_cluster_gives_the_local_rows(ray_cluster: str, tmp_path: Path) -> None:
    argv = ["sweep", "--controller", "mlca-c,mlca_r-py", "--avs", "1,3", "--runs", "1", "--scenario", str(SHORT)]
    assert main([*argv, "--db", str(tmp_path / "ray.sqlite"), "--ray", ray_cluster]) == 0
    assert main([*argv, "--db", str(tmp_path / "local.sqlite")]) == 0
    for table in ("runs", "av_metrics"):
        assert rows(tmp_path / "ray.sqlite", table) == rows(tmp_path / "local.sqlite", table)
    assert len(rows(tmp_path / "ray.sqlite", "runs")) == 4


def test_unreachable_ray_cluster_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["sweep", "--runs", "1", "--avs", "1", "--db", str(tmp_path / "r.sqlite"), "--ray", "127.0.0.1:9"]
    assert main([*argv, "--scenario", str(SHORT)]) == 2
    assert "cannot connect to the Ray cluster at 127.0.0.1:9" in capsys.readouterr().err
