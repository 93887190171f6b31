"""Find where a TOML key or value stands, so that errors can name file, line and column.

`tomllib` gives values but no positions. This scanner reads the same text line by line and records, for every
key path it sees (`("transition", 2, "when")`, `("inputs", "N", "doc")`), the line and column of the value.
It understands table headers, arrays of tables, dotted headers and one-line inline tables, which is every
form the spec format uses; anything it cannot place falls back to the nearest enclosing table.
"""

from __future__ import annotations

import re
from collections import Counter

from mlca_verify.errors import Loc

PathPart = str | int
KeyPath = tuple[PathPart, ...]

_ARRAY_HEADER = re.compile(r"^\s*\[\[\s*(?P<name>[^\]]+?)\s*\]\]")
_TABLE_HEADER = re.compile(r"^\s*\[\s*(?P<name>[^\]]+?)\s*\]")
_KEY = re.compile(r'^\s*(?P<key>[A-Za-z0-9_\-]+|"[^"]*"|\'[^\']*\')\s*=\s*')
_INLINE_KEY = re.compile(r'[{,]\s*(?P<key>[A-Za-z0-9_\-]+|"[^"]*")\s*=\s*')


def _unquote(key: str) -> str:
    key = key.strip()
    return key[1:-1] if key[:1] in "\"'" and key[-1:] == key[:1] else key


def _split_dotted(name: str) -> tuple[str, ...]:
    parts = re.findall(r'"[^"]*"|\'[^\']*\'|[^.]+', name)
    return tuple(_unquote(p) for p in parts)


class Locator:
    """Positions of keys and values in one TOML text."""

    def __init__(self, file: str, text: str) -> None:
        self.file = file
        self.lines = text.splitlines()
        self.values: dict[KeyPath, tuple[int, int]] = {}
        self.keys: dict[KeyPath, tuple[int, int]] = {}
        self._scan()

    def _scan(self) -> None:
        table: KeyPath = ()
        counts: Counter[tuple[str, ...]] = Counter()
        for lineno, line in enumerate(self.lines, start=1):
            if m := _ARRAY_HEADER.match(line):
                name = _split_dotted(m.group("name"))
                table = (*name, counts[name])
                counts[name] += 1
                self.values[table] = (lineno, m.start("name") + 1)
                self.values.setdefault(name, (lineno, m.start("name") + 1))
            elif m := _TABLE_HEADER.match(line):
                table = _split_dotted(m.group("name"))
                self.values[table] = (lineno, m.start("name") + 1)
            elif m := _KEY.match(line):
                path = (*table, _unquote(m.group("key")))
                self.values[path] = (lineno, m.end() + 1)
                self.keys[path] = (lineno, m.start("key") + 1)
                self._scan_inline(path, line, m.end(), lineno)

    def _scan_inline(self, path: KeyPath, line: str, start: int, lineno: int) -> None:
        if not line[start:].lstrip().startswith("{"):
            return
        for m in _INLINE_KEY.finditer(line, start):
            self.values[(*path, _unquote(m.group("key")))] = (lineno, m.end() + 1)
            self.keys[(*path, _unquote(m.group("key")))] = (lineno, m.start("key") + 1)

    def loc(self, path: KeyPath) -> Loc:
        """The value at `path`, or the closest enclosing key or table that was found."""
        for cut in range(len(path), 0, -1):
            if (found := self.values.get(path[:cut])) is not None:
                return Loc(self.file, *found)
        return Loc(self.file, 1, 1)

    def key_loc(self, path: KeyPath) -> Loc:
        """The key itself at `path` (where a name given as a key is wrong), else as `loc`."""
        found = self.keys.get(path)
        return Loc(self.file, *found) if found else self.loc(path)

    def string_loc(self, path: KeyPath, offset: int) -> Loc:
        """The position of character `offset` inside the one-line string value at `path`."""
        base = self.loc(path)
        if path not in self.values:
            return base
        line = self.lines[base.line - 1]
        quote = line[base.col - 1 : base.col]
        if quote not in ("'", '"') or line[base.col - 1 : base.col + 2] in ('"""', "'''"):
            return base
        return Loc(self.file, base.line, base.col + 1 + offset)

    def element_loc(self, path: KeyPath, element: str, occurrence: int = 0) -> Loc:
        """The position of the `occurrence`-th quoted `element` in the array value at `path`."""
        base = self.loc(path)
        pattern = re.compile(r"[\"']" + re.escape(element) + r"[\"']")
        seen = 0
        for index in range(base.line - 1, len(self.lines)):
            start = base.col - 1 if index == base.line - 1 else 0
            for m in pattern.finditer(self.lines[index], start):
                if seen == occurrence:
                    return Loc(self.file, index + 1, m.start() + 1)
                seen += 1
            if "]" in self.lines[index][start:]:
                break
        return base
