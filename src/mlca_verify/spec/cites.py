"""Which elements of a machine cite no source (pure). Shipped specs cite every element; a user's may not, and
`check --require-cites` lists each one instead of refusing the spec at the first."""

from __future__ import annotations

from mlca_verify.errors import Loc
from mlca_verify.model import Machine


def uncited(m: Machine) -> list[tuple[Loc, str]]:
    """(where, what) for every element without a citation, in file order."""
    found: list[tuple[Loc, str]] = []
    if not m.cite:
        found.append((m.loc, f"machine '{m.name}'"))
    groups: list[tuple[str, list[tuple[str, str, Loc]]]] = [
        ("input", [(i.name, i.cite, i.loc) for i in m.inputs]),
        ("param", [(p.name, p.cite, p.loc) for p in m.params]),
        ("signal", [(s.name, s.cite, s.loc) for s in m.signals]),
        ("variable", [(v.name, v.cite, v.loc) for v in m.variables]),
        ("definition", [(d.name, d.cite, d.loc) for d in m.definitions]),
        ("output", [(o.name, o.cite, o.loc) for o in m.outputs]),
        ("assumption", [(a.id, a.cite, a.loc) for a in m.assumptions]),
        ("transition", [(t.id, t.cite, t.loc) for t in m.transitions]),
        ("invariant", [(p.id, p.cite, p.loc) for p in m.invariants]),
        ("liveness property", [(p.id, p.cite, p.loc) for p in m.liveness]),
        ("comparison", [(c.other.name, c.cite, c.loc) for c in m.comparisons]),
    ]
    for kind, items in groups:
        found += [(loc, f"{kind} '{name}'") for name, cite, loc in items if not cite.strip()]
    return sorted(found, key=lambda item: (item[0].line, item[0].col))
