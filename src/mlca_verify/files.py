"""Writing output files whole: a regular file is written beside its destination and renamed over it, so that an
interrupted or failed write (Ctrl-C, a full disk) leaves the previous file, never a truncated one.

Only regular files are replaced. A symbolic link is followed (its target is replaced, the link kept), and a
destination that is not a regular file (a device such as /dev/null, a FIFO, /dev/stdout) is written through,
never replaced.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

_SPECIAL_TREES = ("/dev/", "/proc/")  # /dev/stdout and /proc/self/fd/N name open streams, not files to replace


def _written_through(path: Path) -> bool:
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return False
    resolved = os.path.realpath(path)
    return not stat.S_ISREG(mode) or str(path).startswith(_SPECIAL_TREES) or resolved.startswith(_SPECIAL_TREES)


def write_atomic(path: Path, data: str | bytes) -> None:
    """Replace `path` with `data` (text is written as UTF-8) in one rename. Raises OSError like a plain write."""
    payload = data.encode("utf-8") if isinstance(data, str) else data
    if _written_through(path):
        with open(path, "wb") as out:
            out.write(payload)
        return
    target = Path(os.path.realpath(path))
    temporary = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        with open(temporary, "wb") as out:
            out.write(payload)
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
