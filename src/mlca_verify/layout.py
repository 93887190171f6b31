"""Where the generated files of a machine live: the one place that names them (gen and its drift check, conform,
emit, evidence and the closed loop all find them through `Layout`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

FILES = {"python": "python/{module}_fsm.py", "c-header": "c/{module}_fsm.h", "c-source": "c/{module}_fsm.c"}
GENERATED_GLOBS = ("*/*_fsm.*", "*/*_frames.*")  # every file a machine's layout or a network's frames hold


@dataclass(frozen=True)
class Layout:
    """Where the generated files of the machine `module` live under the folder `root` (`generated/`)."""

    root: Path
    module: str

    def relative(self, kind: str) -> str:
        """The path of one kind of file (a key of FILES) relative to `root`."""
        return FILES[kind].format(module=self.module)

    @property
    def python(self) -> Path:
        """The generated Python module."""
        return self.root / self.relative("python")

    @property
    def c_source(self) -> Path:
        """The generated C source."""
        return self.root / self.relative("c-source")

    @property
    def c_header(self) -> Path:
        """The generated C header."""
        return self.root / self.relative("c-header")

    def missing(self) -> list[Path]:
        """The generated files that are not there."""
        return [p for p in (self.python, self.c_header, self.c_source) if not p.is_file()]
