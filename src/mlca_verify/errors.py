"""The project's one exception tree. Every message carries its location and the bad value."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Self

from mlca_verify.escape import terminal

MESSAGE_LIMIT = 500  # characters of a message after its location


def located(where: object, message: str) -> str:
    """An error line as every tool writes one, `where: error: message`: the one place that writes the prefix;
    the location is made one line."""
    return f"{terminal(str(where))}: error: {message}"


@dataclass(frozen=True)
class Loc:
    """A position in a source file (1-based line and column)."""

    file: str
    line: int
    col: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


class MlcaError(Exception):
    """Base of every error the toolkit raises on purpose."""

    @classmethod
    def at(cls, where: object, message: str) -> Self:
        """The error of `where` (a file, a spec location, a database, a folder), as every tool writes one:
        `where: error: message` (see `located`)."""
        return cls(located(where, message))


class SpecError(MlcaError):
    """A spec file that cannot be loaded: bad TOML, bad shape, or bad meaning."""

    def __init__(self, loc: Loc, message: str) -> None:
        message = terminal(message)  # spec text in a message: one line, no control character
        if len(message) > MESSAGE_LIMIT:
            message = message[: MESSAGE_LIMIT - 3] + "..."
        super().__init__(located(loc, message))
        self.loc = loc
        self.message = message


class UsageError(MlcaError):
    """A command used wrongly (missing file, incompatible options)."""


class CodegenError(MlcaError):
    """A machine that cannot be turned into code (nondeterministic, with gaps), or a template problem."""


class ToolError(MlcaError):
    """An external tool (compiler, prover, checker) that is missing or failed to run."""
