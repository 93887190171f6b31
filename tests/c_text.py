"""Reading the generated C in tests: one function's text."""

from __future__ import annotations


def c_function(source: str, header: str) -> str:
    """The text of the C function whose definition starts with `header`, to its closing brace."""
    start = source.index(f"\n{header}")
    return source[start : source.index("\n}\n", start)]
