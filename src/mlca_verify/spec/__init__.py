"""Load a spec file: TOML syntax, then shape, then meaning. Every failure is a one-line `SpecError`."""

from __future__ import annotations

import hashlib
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.errors import Loc, SpecError, UsageError
from mlca_verify.files import read_regular
from mlca_verify.model import Machine
from mlca_verify.network import Network
from mlca_verify.spec.locate import Locator
from mlca_verify.spec.meaning import LoadOther, MeaningChecker
from mlca_verify.spec.network import LoadInstance, NetworkLoader, is_network
from mlca_verify.spec.shape import ShapeChecker

__all__ = ["LoadedSpec", "load_spec", "load_text", "machine_specs", "names_a_network"]

MAX_SPEC_BYTES = 2_000_000
NOT_A_MACHINE = "a network spec: every command but `tests` takes it; `tests` takes each instance's machine spec"
_TOML_POS = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


@dataclass(frozen=True)
class LoadedSpec:
    """A machine with the file it came from and the file's sha256. A network spec's `machine` is the one machine
    its instances and channels make (`network.flatten`), and `network` the network itself."""

    path: str
    sha256: str
    machine: Machine
    network: Network | None = None


def _toml_error(file: str, err: tomllib.TOMLDecodeError) -> SpecError:
    text = str(err)
    m = _TOML_POS.search(text)
    loc = Loc(file, int(m.group(1)), int(m.group(2))) if m else Loc(file, 1, 1)
    message = _TOML_POS.sub("", text)
    return SpecError(loc, f"invalid TOML: {message[:1].lower()}{message[1:]}")


def load_text(text: str, file: str, load_other: LoadOther | None = None) -> Machine:
    """Parse and check spec text; `file` is only used in messages."""
    return _load_text(text, file, load_other, None)[0]


def _load_text(
    text: str, file: str, load_other: LoadOther | None, load_instance: LoadInstance | None
) -> tuple[Machine, Network | None]:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise _toml_error(file, err) from None
    except RecursionError:
        raise SpecError(Loc(file, 1, 1), "invalid TOML: arrays or tables nested too deeply") from None
    where = Locator(file, text)
    if is_network(doc):
        if load_instance is None:
            raise SpecError(where.loc(("network",)), NOT_A_MACHINE)
        network, machine = NetworkLoader(doc, where, load_instance).build()
        return machine, network
    ShapeChecker(doc, where).check()
    return MeaningChecker(doc, where, load_other).build(), None


def _read(path: Path) -> tuple[str, str]:
    data = read_regular(path, MAX_SPEC_BYTES, "spec")
    try:
        return data.decode("utf-8"), hashlib.sha256(data).hexdigest()
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        col = err.start - (data.rfind(b"\n", 0, err.start) + 1) + 1
        raise SpecError(Loc(str(path), line, col), f"spec is not UTF-8 text (byte 0x{data[err.start]:02x})") from None


def names_a_network(path: Path) -> bool:
    """Whether `path` is a network spec (False for a file that is not a spec this can read)."""
    try:
        return is_network(tomllib.loads(_read(path)[0]))
    except (OSError, SpecError, UsageError, tomllib.TOMLDecodeError, RecursionError):
        return False


def _inside(path: Path, folders: list[Path]) -> bool:
    resolved = path.resolve()
    return any(resolved.is_relative_to(folder.resolve()) for folder in folders)


def load_spec(path: str | Path, compare: bool = True, confine: bool = True, network: bool = False) -> LoadedSpec:
    """Load a spec file. With `compare`, machines named in `[[compare]]` are loaded too (one level); with
    `confine`, only from the spec's own folder tree or the working directory's. A network spec (its instances'
    machine specs found the same way) only with `network`."""
    path = Path(path)
    text, digest = _read(path)

    def load_other(name: str, loc: Loc) -> Machine:
        return _other(path, name, loc, "compared", confine)

    def load_instance(name: str, loc: Loc) -> Machine:
        return _other(path, name, loc, "instance's", confine)

    machine, found = _load_text(text, str(path), load_other if compare else None, load_instance if network else None)
    return LoadedSpec(str(path), digest, machine, found)


def machine_specs(loaded: LoadedSpec) -> list[LoadedSpec]:
    """The machine specs a loaded spec stands for: itself, or a network's instances' machine specs, each once (the
    instances share their machine's code), in the order of the instances."""
    if loaded.network is None:
        return [loaded]
    found: dict[Path, LoadedSpec] = {}
    for inst in loaded.network.instances:
        where = Path(loaded.path).parent / inst.spec
        if where.resolve() not in found:
            found[where.resolve()] = load_spec(where, compare=False)
    return list(found.values())


def _other(path: Path, name: str, loc: Loc, what: str, confine: bool) -> Machine:
    """The machine of a spec another one names (relative to its folder): compared with it, or an instance."""
    if "\x00" in name:
        raise SpecError(loc, f"{what} spec {name[:80]!r} holds a NUL byte")
    try:
        other = path.parent / name
        if confine and not _inside(other, [path.parent, Path.cwd()]):
            raise SpecError(
                loc,
                f"{what} spec {name[:80]!r} lies outside the spec's folder and the working directory "
                "(--allow-outside lifts this)",
            )
        if not other.is_file():
            raise SpecError(loc, f"{what} spec {name[:80]!r} not found (looked for {str(other)[:200]})")
        return load_spec(other, compare=False, confine=confine).machine
    except OSError as err:
        raise SpecError(loc, f"{what} spec {name[:80]!r} cannot be read: {err.strerror or err}") from None
