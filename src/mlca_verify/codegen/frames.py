"""The messages of a network as frames (pure): what each channel carries, its kind (a boolean, an int, a real)
and the fixed-size little-endian frame the generated encoder writes and the generated decoder checks, in C and in
Python, so that two ECUs, or an ECU and a test bench, exchange a network's messages with nothing left to
interpretation.

A frame is FRAME_BYTES bytes: the format's version, the frame's length, the channel's index in the network (its
order of declaration), the kind of value, and eight bytes of payload, little-endian (a boolean in the first of
them as 0 or 1, the others zero; an int as a two's-complement int64; a real as the bits of its binary64). The
decoder rejects, and never reads, a frame of another length, version or declared length, an unknown channel, a
kind other than the channel's, a boolean byte other than 0 or 1, and padding that is not zero. What a value
means once read (an invalid sample, out of its signal's range) is the receiver's spec's business.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from mlca_verify.network import Channel, Network
from mlca_verify.spec import LoadedSpec

FRAME_BYTES = 12
FRAME_VERSION = 1
Kind = Literal["bool", "int", "real"]
KIND_CODES: dict[Kind, int] = {"bool": 1, "int": 2, "real": 3}
FRAME_FILES = {
    "python": "python/{module}_frames.py",
    "c-header": "c/{module}_frames.h",
    "c-source": "c/{module}_frames.c",
}
FRAME_TEMPLATES = {"python": "python_frames.py.j2", "c-header": "c_frames.h.j2", "c-source": "c_frames.c.j2"}


@dataclass(frozen=True)
class FrameChannel:
    """One channel of the network, as its frames name it."""

    index: int
    channel: Channel
    kind: Kind

    @property
    def code(self) -> int:
        return KIND_CODES[self.kind]


@dataclass(frozen=True)
class FramesIR:
    """What the frame templates read: the network, where it came from, and its channels."""

    name: str
    module: str
    spec_path: str
    spec_sha256: str
    generator: str
    cite: str
    channels: tuple[FrameChannel, ...]

    @property
    def upper(self) -> str:
        return self.module.upper()


def kind_of(net: Network, ch: Channel) -> Kind:
    """The kind of value a channel carries: what its receiving port reads (a boolean input, or a signal)."""
    receiver = net.instance(ch.receiver).machine
    signal = next((s for s in receiver.signals if s.name == ch.port), None)
    return "bool" if signal is None else signal.type


def frames_ir(spec: LoadedSpec, out_dir: Path, generator: str) -> FramesIR:
    """The frames of a loaded network spec; its path recorded relative to the folder that holds `out_dir`."""
    net = spec.network
    assert net is not None
    rel = Path(os.path.relpath(Path(spec.path).resolve(), out_dir.resolve().parent)).as_posix()
    channels = tuple(FrameChannel(k, ch, kind_of(net, ch)) for k, ch in enumerate(net.channels))
    return FramesIR(net.name, frames_module(net.name), rel, spec.sha256, generator, net.cite, channels)


def frames_module(name: str) -> str:
    """The file-name and C-prefix stem of a network named `name`'s frames."""
    return re.sub(r"[^a-z0-9_]", "_", name.lower())


def frame_files(module: str) -> dict[str, str]:
    """Kind -> the relative path of each generated frame file of a network named `module`."""
    return {kind: path.format(module=module) for kind, path in FRAME_FILES.items()}
