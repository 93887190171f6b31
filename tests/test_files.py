"""Output files are written whole (an interrupted write leaves the previous file and no stray temporary), and
Ctrl-C ends a command with a message."""

from __future__ import annotations

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
