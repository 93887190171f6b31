"""Output files are written whole (an interrupted write leaves the previous file and no stray temporary), and
Ctrl-C ends a command with a message."""

from __future__ import annotations

import os
from pathlib import Path
from types import ModuleType

import pytest

from mlca_verify import cli as mlca_cli
from mlca_verify import files
from mlca_verify.files import write_atomic
from sim_check import cli as sim_cli


def test_text_and_bytes_are_written(tmp_path: Path) -> None:
    write_atomic(tmp_path / "a.txt", "ü\n")
    write_atomic(tmp_path / "b.bin", b"\x00\x01")
    assert (tmp_path / "a.txt").read_bytes() == "ü\n".encode()
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.bin"]


def test_an_interrupted_write_keeps_the_previous_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "evidence.json"
    target.write_text("previous\n")

    def interrupted(src: object, dst: object) -> None:
        raise KeyboardInterrupt  # Ctrl-C after the new text is written, before it replaces the old

    monkeypatch.setattr(files.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_atomic(target, "new\n")
    assert target.read_text() == "previous\n"
    assert list(tmp_path.iterdir()) == [target]


def test_a_failed_write_raises_and_leaves_nothing(tmp_path: Path) -> None:
    with pytest.raises(OSError):
        write_atomic(tmp_path / "missing" / "x.txt", "text")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("cli", [mlca_cli, sim_cli])
def test_ctrl_c_ends_a_command_with_130_and_no_traceback(
    cli: ModuleType, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def interrupted() -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "main", interrupted)
    with pytest.raises(SystemExit) as ended:
        cli.entry()
    assert ended.value.code == 130
    assert capsys.readouterr().err == "\ninterrupted\n"


def test_a_device_is_written_through_not_replaced(tmp_path: Path) -> None:
    before = Path("/dev/null").stat()
    write_atomic(Path("/dev/null"), "{}\n")
    after = Path("/dev/null").stat()
    assert (after.st_ino, after.st_mode, after.st_rdev) == (before.st_ino, before.st_mode, before.st_rdev)


def test_a_fifo_is_written_through(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        write_atomic(fifo, "through\n")
        assert os.read(reader, 100) == b"through\n"
    finally:
        os.close(reader)
    assert fifo.is_fifo()


def test_a_symlink_keeps_its_link_and_its_target_is_replaced(tmp_path: Path) -> None:
    target = tmp_path / "real.json"
    target.write_text("old\n")
    link = tmp_path / "link.json"
    link.symlink_to(target.name)
    write_atomic(link, "new\n")
    assert link.is_symlink()
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.json", "real.json"]


def test_json_to_dev_stdout_reaches_the_output(capfd: pytest.CaptureFixture[str]) -> None:
    spec = str(Path(__file__).resolve().parents[1] / "spec" / "mlca.toml")
    assert mlca_cli.main(["check", spec, "--only", "A3", "--quiet", "--json", "/dev/stdout"]) == 0
    out = capfd.readouterr().out
    assert '"schema": "mlca-verify.check/' in out


def test_a_rewritten_file_keeps_its_permissions(tmp_path: Path) -> None:
    target = tmp_path / "private.json"
    target.write_text("old\n")
    target.chmod(0o600)
    write_atomic(target, "new\n")
    assert target.read_text() == "new\n"
    assert target.stat().st_mode & 0o777 == 0o600
