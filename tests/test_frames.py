"""A network's messages as frames: `gen` of a network writes an encoder and a decoder in C and in Python; both
write the same bytes, read back what was written, and reject the same malformed frames, never reading them."""

from __future__ import annotations

import ctypes
import importlib.util
import math
import struct
import subprocess
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mlca_verify.cli import main

METER = """[machine]
name = "Meter"
initial = "ON"
states = ["ON"]
[inputs]
go = { doc = "a request" }
[outputs]
count = { type = "int", expr = "3", range = [0, 9], doc = "a count" }
reading = { type = "real", expr = "2.5", doc = "a reading" }
flag = { type = "bool", expr = "state == ON", doc = "a flag" }
"""

DISPLAY = """[machine]
name = "Display"
initial = "OFF"
states = ["OFF", "ON"]
[inputs]
flag_in = { doc = "the flag" }
[signals]
n = { type = "int", unit = "1", range = [0, 9], doc = "a count" }
x = { type = "real", unit = "1", range = [0.0, 10.0], doc = "a reading" }
[definitions]
high = { expr = "n > 2 and x > 1.0", if_invalid = false, doc = "a high count and reading" }
[[transition]]
id = "on"
from = "OFF"
to = "ON"
when = "flag_in and high"
"""

PANEL = """[network]
name = "Panel"
cite = "a <test> network"
[instances.M]
spec = "meter.toml"
[instances.D]
spec = "display.toml"
[[channel]]
id = "to-flag"
from = "M.flag"
to = "D.flag_in"
[[channel]]
id = "to_n"
from = "M.count"
to = "D.n"
[[channel]]
id = "to_x"
from = "M.reading"
to = "D.x"
"""

KINDS = (1, 2, 3)  # the channels of PANEL: a boolean, an int, a real
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion", "-O2", "-fPIC", "-shared"]


class Message(ctypes.Structure):
    _fields_ = [("channel", ctypes.c_uint8), ("b", ctypes.c_bool), ("i", ctypes.c_int64), ("r", ctypes.c_double)]


@pytest.fixture(scope="module")
def codecs(tmp_path_factory: pytest.TempPathFactory) -> tuple[ModuleType, Any]:
    """PANEL's frames generated, the Python module imported and the C compiled with the conformance flags."""
    root = tmp_path_factory.mktemp("frames")
    for name, text in (("meter.toml", METER), ("display.toml", DISPLAY), ("panel.toml", PANEL)):
        (root / name).write_text(text, encoding="utf-8")
    assert main(["gen", "--out", str(root / "generated"), str(root / "panel.toml")]) == 0
    spec = importlib.util.spec_from_file_location("panel_frames", root / "generated" / "python" / "panel_frames.py")
    assert spec is not None and spec.loader is not None
    py = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(py)
    lib = root / "libpanel_frames.so"
    source = root / "generated" / "c" / "panel_frames.c"
    subprocess.run(["gcc", *FLAGS, "-o", str(lib), str(source)], check=True, capture_output=True, text=True)
    c = ctypes.CDLL(str(lib))
    c.panel_encode.argtypes = [ctypes.POINTER(Message), ctypes.c_char_p]
    c.panel_decode.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(Message)]
    return py, c


def _c_encode(c: Any, channel: int, value: Any) -> tuple[int, bytes]:
    msg = Message(channel, bool(value) if KINDS[channel] == 1 else False, 0, 0.0)
    if KINDS[channel] == 2:
        msg.i = value
    if KINDS[channel] == 3:
        msg.r = value
    out = ctypes.create_string_buffer(12)
    status = c.panel_encode(ctypes.byref(msg), out)
    return status, out.raw


def _c_decode(c: Any, frame: bytes) -> tuple[int, Any]:
    msg = Message(0, False, 0, 0.0)
    status = c.panel_decode(frame, len(frame), ctypes.byref(msg))
    value = (msg.b, msg.i, msg.r)[KINDS[msg.channel] - 1] if status == 0 else None
    return status, (msg.channel, value)


def _py_decode(py: ModuleType, frame: bytes) -> tuple[int, Any]:
    try:
        return 0, py.decode(frame)
    except py.FrameError as err:
        return err.status, None


VALUES = {
    1: st.booleans(),
    2: st.integers(-(2**63), 2**63 - 1),
    3: st.floats(allow_nan=True, allow_infinity=True),
}


@settings(max_examples=150, deadline=None, derandomize=True)
@given(data=st.data())
def test_c_and_python_write_the_same_frame_and_read_back_the_value(
    codecs: tuple[ModuleType, Any], data: st.DataObject
) -> None:
    py, c = codecs
    channel = data.draw(st.integers(0, 2))
    value = data.draw(VALUES[KINDS[channel]])
    frame = py.encode(channel, value)
    assert _c_encode(c, channel, value) == (0, frame) and len(frame) == py.FRAME_BYTES == 12
    assert frame[:4] == bytes([1, 12, channel, KINDS[channel]])
    for status, (got_channel, got) in (_c_decode(c, frame), _py_decode(py, frame)):
        assert status == 0 and got_channel == channel
        if KINDS[channel] == 3:  # the same binary64, NaN's bits included
            assert struct.pack("<d", got) == struct.pack("<d", value)
        else:
            assert got == value


@settings(max_examples=300, deadline=None, derandomize=True)
@given(data=st.data())
def test_a_malformed_frame_is_rejected_alike_in_c_and_python(
    codecs: tuple[ModuleType, Any], data: st.DataObject
) -> None:
    """Random bytes, and well-formed frames with one byte changed or cut short: C and Python accept and reject the
    same ones, with the same status, and read the same value from those they accept."""
    py, _ = codecs
    channel = data.draw(st.integers(0, 2))
    good = bytearray(py.encode(channel, data.draw(VALUES[KINDS[channel]])))
    mangled = data.draw(
        st.one_of(
            st.binary(max_size=16),
            st.tuples(st.integers(0, 11), st.integers(0, 255)).map(lambda kv: _with(good, *kv)),
            st.integers(0, 11).map(lambda n: bytes(good[:n])),
        )
    )
    c_status, c_read = _c_decode(codecs[1], mangled)
    py_status, py_read = _py_decode(py, mangled)
    assert c_status == py_status
    if c_status == 0:
        assert _same(c_read, py_read)


def _with(frame: bytearray, at: int, byte: int) -> bytes:
    changed = bytearray(frame)
    changed[at] = byte
    return bytes(changed)


def _same(a: tuple[int, Any], b: tuple[int, Any]) -> bool:
    if isinstance(a[1], float):
        return a[0] == b[0] and (struct.pack("<d", a[1]) == struct.pack("<d", b[1]) or math.isnan(a[1]))
    return a == b


@pytest.mark.parametrize(
    ("frame", "status"),
    [
        (bytes([1, 12, 0, 1, 1]) + bytes(7), 0),
        (bytes([1, 12, 0, 1, 2]) + bytes(7), 5),  # a boolean is 0 or 1
        (bytes([1, 12, 0, 1, 1, 0, 0, 1]) + bytes(4), 5),  # its padding is zero
        (bytes([2, 12, 0, 1, 1]) + bytes(7), 2),  # another version
        (bytes([1, 11, 0, 1, 1]) + bytes(7), 1),  # a declared length that is not the frame's
        (bytes([1, 12, 0, 1, 1]) + bytes(6), 1),  # a frame cut short
        (bytes([1, 12, 3, 1, 1]) + bytes(7), 3),  # no channel 3
        (bytes([1, 12, 1, 3, 1]) + bytes(7), 4),  # channel 1 carries an int, not a real
    ],
)
def test_each_malformed_frame_has_its_status(codecs: tuple[ModuleType, Any], frame: bytes, status: int) -> None:
    py, c = codecs
    assert _c_decode(c, frame)[0] == _py_decode(py, frame)[0] == status


def test_encoding_on_a_channel_the_network_lacks_writes_nothing(codecs: tuple[ModuleType, Any]) -> None:
    py, c = codecs
    out = ctypes.create_string_buffer(12)
    assert c.panel_encode(ctypes.byref(Message(3, True, 0, 0.0)), out) == 3 and out.raw == bytes(12)
    with pytest.raises(py.FrameError):
        py.encode(3, True)


def test_the_channels_are_named_and_spec_text_reaches_the_code_escaped(tmp_path: Path) -> None:
    for name, text in (("meter.toml", METER), ("display.toml", DISPLAY), ("panel.toml", PANEL)):
        (tmp_path / name).write_text(text, encoding="utf-8")
    assert main(["gen", "--out", str(tmp_path / "g"), str(tmp_path / "panel.toml")]) == 0
    header = (tmp_path / "g" / "c" / "panel_frames.h").read_text(encoding="utf-8")
    assert "PANEL_TO_FLAG = 0, /* M.flag to D.flag_in, bool */" in header
    assert "PANEL_TO_N = 1," in header and "PANEL_TO_X = 2 /* M.reading to D.x, real */" in header
    assert "The messages of the network Panel (a <test> network)" in header
    python = (tmp_path / "g" / "python" / "panel_frames.py").read_text(encoding="utf-8")
    assert 'CHANNELS = ("to-flag", "to_n", "to_x")\nKINDS = (1, 2, 3)\n' in python


def test_gen_check_finds_a_frame_file_no_network_produces(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name, text in (("meter.toml", METER), ("display.toml", DISPLAY), ("panel.toml", PANEL)):
        (tmp_path / name).write_text(text, encoding="utf-8")
    out = tmp_path / "g"
    assert main(["gen", "--out", str(out), str(tmp_path / "panel.toml")]) == 0
    written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*_frames.*"))
    assert written == ["c/panel_frames.c", "c/panel_frames.h", "python/panel_frames.py"]
    (out / "c" / "renamed_frames.h").write_text("/* an old network's */\n", encoding="utf-8")
    capsys.readouterr()
    assert main(["gen", "--check", "--out", str(out), str(tmp_path / "panel.toml")]) == 1
    assert "renamed_frames.h: is not generated by any of the specs" in capsys.readouterr().out
