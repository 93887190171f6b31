"""Writing output files whole: a regular file is written beside its destination and renamed over it, so that an
interrupted or failed write (Ctrl-C, a full disk) leaves the previous file, never a truncated one.

Only regular files are replaced. A symbolic link is followed (its target is replaced, the link kept), and a
destination that is not a regular file (a device such as /dev/null, a FIFO, /dev/stdout) is written through,
never replaced.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from mlca_verify.errors import UsageError

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
    fd, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")  # O_EXCL: no link
    temporary = Path(name)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(payload)
        os.chmod(temporary, _mode_for(target))
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def _mode_for(target: Path) -> int:
    """The permissions the file keeps (an existing one's), or those a new file gets under the umask."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def read_regular(path: Path, limit: int, what: str) -> bytes:
    """The bytes of the regular file `path`, of at most `limit` bytes; anything else (missing, a FIFO, a device
    such as /dev/zero, too large, a NUL byte in the name) is a one-line `UsageError` naming `what` it is, read
    no further than `limit` bytes and never blocking."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except ValueError:
        raise UsageError.at(repr(str(path)), f"cannot read {what}: the name holds a NUL byte") from None
    except OSError as err:
        raise UsageError.at(path, f"cannot read {what}: {err.strerror or err}") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = "a directory" if stat.S_ISDIR(mode) else "not a regular file"
        raise UsageError.at(path, f"cannot read {what}: {kind}")
    with os.fdopen(fd, "rb") as file:
        try:
            data = file.read(limit + 1)
        except OSError as err:
            raise UsageError.at(path, f"cannot read {what}: {err.strerror or err}") from None
    if len(data) > limit:
        raise UsageError.at(path, f"{what} larger than {limit:,} bytes")
    return data
