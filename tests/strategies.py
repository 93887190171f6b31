"""Hypothesis strategies: random machines (up to 8 states and 5 inputs, both semantics, both otherwise modes)."""

from __future__ import annotations

from dataclasses import replace

from hypothesis import strategies as st

from mlca_verify.errors import Loc
from mlca_verify.model import (
    BinOp,
    Const,
    Expr,
    Input,
    Invariant,
    Liveness,
    Machine,
    Not,
    StateIn,
    Transition,
    Var,
    show,
)

HERE = Loc("<random>", 1, 1)


def exprs(inputs: tuple[str, ...], states: tuple[str, ...] = ()) -> st.SearchStrategy[Expr]:
    leaves: list[st.SearchStrategy[Expr]] = [st.sampled_from(inputs).map(Var), st.booleans().map(Const)]
    if states:
        subsets = st.lists(st.sampled_from(states), min_size=1, max_size=len(states), unique=True)
        leaves.append(subsets.map(lambda xs: StateIn(tuple(xs))))
    ops = st.sampled_from(["and", "or", "->", "<->"])

    def extend(inner: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
        binary = st.tuples(ops, inner, inner).map(lambda t: BinOp(t[0], t[1], t[2]))
        return st.one_of(inner.map(Not), binary)

    return st.recursive(st.one_of(*leaves), extend, max_leaves=6)


@st.composite
def machines(draw: st.DrawFn, max_states: int = 8, max_inputs: int = 5, name: str = "M") -> Machine:
    states = tuple(f"S{i}" for i in range(draw(st.integers(1, max_states))))
    inputs = tuple(f"I{i}" for i in range(draw(st.integers(1, max_inputs))))
    return draw(machines_over(states, inputs, name))


@st.composite
def machines_over(draw: st.DrawFn, states: tuple[str, ...], inputs: tuple[str, ...], name: str = "M") -> Machine:
    guard = exprs(inputs)
    sources = st.one_of(st.none(), st.lists(st.sampled_from(states), min_size=1, max_size=3, unique=True).map(tuple))
    raw = draw(st.lists(st.tuples(sources, st.sampled_from(states), guard), max_size=12))
    transitions = tuple(
        Transition(f"t{k + 1}", src, dst, g, f"cite {k + 1}", HERE) for k, (src, dst, g) in enumerate(raw)
    )
    invariants = tuple(
        Invariant(f"inv{k}", e, "cite", "holds", HERE)
        for k, e in enumerate(draw(st.lists(exprs(inputs, states), max_size=2)))
    )
    within = st.one_of(st.none(), st.integers(1, 4))
    lives = draw(st.lists(st.tuples(exprs(inputs), exprs(inputs, states), within), max_size=2))
    liveness = tuple(Liveness(f"live{k}", a, g, w, "cite", "holds", HERE) for k, (a, g, w) in enumerate(lives))
    return Machine(
        name=name,
        initial=draw(st.sampled_from(states)),
        states=states,
        inputs=tuple(Input(n, "doc", "cite", HERE) for n in inputs),
        transitions=transitions,
        semantics=draw(st.sampled_from(["first-match", "any-enabled"])),
        otherwise=draw(st.sampled_from(["stay", "undefined"])),
        cite="cite",
        invariants=invariants,
        liveness=liveness,
    )


def _toml_list(names: tuple[str, ...]) -> str:
    return "[" + ", ".join(f'"{n}"' for n in names) + "]"


def spec_text(m: Machine) -> str:
    """A machine without data as the spec file that loads as it (names and guards as the strategies draw them)."""
    lines = [
        "[machine]",
        f'name = "{m.name}"',
        f'initial = "{m.initial}"',
        f"states = {_toml_list(m.states)}",
        f'semantics = "{m.semantics}"',
        f'otherwise = "{m.otherwise}"',
        "",
        "[inputs]",
        *(f'{i.name} = {{ doc = "{i.doc}" }}' for i in m.inputs),
    ]
    for t in m.transitions:
        source = '"*"' if t.sources is None else _toml_list(t.sources)
        lines += ["", "[[transition]]", f'id = "{t.id}"', f"from = {source}", f'to = "{t.target}"']
        lines.append(f'when = "{show(t.guard)}"')
    for inv in m.invariants:
        lines += ["", "[[invariant]]", f'id = "{inv.id}"', f'expr = "{show(inv.expr)}"']
    for live in m.liveness:
        lines += [
            "",
            "[[liveness]]",
            f'id = "{live.id}"',
            f'assume = "{show(live.assume)}"',
            f'goal = "{show(live.goal)}"',
        ]
        lines += [f"within = {live.within}"] if live.within is not None else []
    return "\n".join(lines) + "\n"


def boolean_specs() -> st.SearchStrategy[str]:
    """Spec files of machines without data, first-match (the semantics the generator takes)."""
    return machines(max_states=4, max_inputs=3, name="B").map(lambda m: spec_text(replace(m, semantics="first-match")))
