"""The types of the JSON documents the toolkit writes: a value is what `json.dumps` takes and `json.loads` gives."""

from __future__ import annotations

from typing import TypeAlias

Json: TypeAlias = "bool | int | float | str | list[Json] | dict[str, Json] | None"
JsonObject: TypeAlias = "dict[str, Json]"

__all__ = ["Json", "JsonObject"]
