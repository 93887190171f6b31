"""Why the code keeps a gap the suite cannot close: each uncovered line, branch or MC/DC condition of the
generated code is traced to the spec element its line implements (the generated code names it in a comment or a
docstring), and given the reasons z3 found for that element's conditions without a pair."""

from __future__ import annotations

import re
from collections.abc import Collection, Sequence
from dataclasses import dataclass

from mlca_verify.model import Call, Expr, Machine, name_types, names_of, nodes, show, type_of
from mlca_verify.testgen.coupling import coupling_reason
from mlca_verify.testgen.definition_reads import read_through
from mlca_verify.testgen.measure import Gap
from mlca_verify.testgen.search import Pair

DIVISION = (
    "a division by zero, which the spec's divisors never are for params within their ranges (the division "
    "checks of `mlca-verify check` prove it)"
)
_C_TAG = re.compile(r"/\* ([A-Za-z0-9_.-]+)(?:: | \*/)")
_PY_TAG = re.compile(r"(?:# |\"\"\")([A-Za-z0-9_.-]+): ")
_APPEND = re.compile(r"\.append\(\"([A-Za-z0-9_.-]+)\"\)")
_DEFINITION = re.compile(r"_def_([A-Za-z0-9_]+)\(")
_HELPER = re.compile(r"_((?:min|max|abs)(?:_[id])?)\(")  # the C helpers are per type: min_i on ints, min_d on reals
_MODE_CASE = re.compile(r"c\.mode == State\.([A-Za-z0-9_]+):")  # the Python `_fired`'s case of one mode
_STATE_FUNCTION = re.compile(r"\w+_state_t \w+\(")  # a C function that returns a mode (a direct step's chain)
_STATE_CASE = re.compile(r"\((?:c->)?mode == ([A-Z0-9_]+)\) \{")  # a mode's block of a direct step
# the C function of one mode's chain: the transition's number, or the next mode itself in a direct step
_MODE_FUNCTION = re.compile(r"_(?:fired|to)_([A-Za-z0-9_]+)\(")
_OTHERWISE = re.compile(r"otherwise: the mode is kept")
_EVERY = re.compile(r"\b(?:next|nxt)\.([A-Za-z0-9_]+) = .*(?:/\* |# )every step: ")  # a variable's every rule
_OUTPUT = re.compile(r"^\s*(?:o->([A-Za-z0-9_]+) = |([A-Za-z0-9_]+)=)")  # an output's line, in C or in Python
_FIRED = re.compile(r"\bfired == (\d+)\b")  # the step's branch of one transition (numbered from 1, in spec order)
_ELSE = re.compile(r"^\s*(?:\} )?else(?::| \{)")  # the last branch of a chain, in Python or in C
LOOK_BACK = 3  # lines above a gap searched for the comment naming its element


def element_of(lines: Sequence[str], line: int, known: set[str], numbered: Sequence[str] = ()) -> str | None:
    """The spec element named on the gap's line, in a comment just above it, by the monitor's verdict on the
    line below, or by the number of the transition whose branch of the step holds it (`numbered`, from 1)."""
    for k in (line - 1, line):  # the verdict on the gap's own line, or on the line below it
        verdict = _APPEND.search(lines[k]) if k < len(lines) else None
        if verdict and verdict.group(1) in known:
            return verdict.group(1)
    every = _EVERY.search(lines[line - 1]) if 0 < line <= len(lines) else None
    if every and every.group(1) in known:
        return every.group(1)
    output = _OUTPUT.match(lines[line - 1]) if 0 < line <= len(lines) else None
    if output and (output.group(1) or output.group(2)) in known:
        return output.group(1) or output.group(2)
    for k in range(line - 1, max(line - 1 - LOOK_BACK, -1), -1):
        text = lines[k]
        for match in (*_C_TAG.finditer(text), *_PY_TAG.finditer(text)):
            if match.group(1) in known:
                return match.group(1)
        branch = _FIRED.search(text)
        if branch and 0 < int(branch.group(1)) <= len(numbered):
            return numbered[int(branch.group(1)) - 1]
        if k < line - 1 and not text.strip().startswith(("#", "/*", "*", "if ")):  # a comment, or the if it is under
            break
    name = _header_match(lines, line, _DEFINITION)
    return name if name in known else None


def _header_match(lines: Sequence[str], line: int, pattern: re.Pattern[str]) -> str | None:
    """The first group of `pattern` in the header of the function holding the gap's line, if it matches."""
    header = _header(lines, line)
    match = pattern.search(header.split("(")[0] + "(") if header else None
    return match.group(1) if match else None


def _is_header(text: str) -> bool:
    return text.startswith(("def ", "static ", "bool ", "void ", "int ")) or _STATE_FUNCTION.match(text) is not None


def _header(lines: Sequence[str], line: int) -> str | None:
    for k in range(line - 1, -1, -1):
        if _is_header(lines[k]):
            return lines[k]
    return None


def in_function(lines: Sequence[str], line: int, names: tuple[str, ...]) -> bool:
    header = _header(lines, line)
    return header is not None and any(n in header.split("(")[0] for n in names)


def _expressions(machine: Machine) -> list[Expr]:
    exprs: list[Expr] = [t.guard for t in machine.transitions]
    exprs += [u.expr for t in machine.transitions for u in t.updates]
    exprs += [v.every for v in machine.variables if v.every is not None]
    exprs += [d.expr for d in machine.definitions] + [o.expr for o in machine.outputs]
    return exprs + [i.expr for i in machine.invariants]  # the monitor's checks call the same helpers


def saturation(machine: Machine, helper: str, depth: int) -> str:
    """Why a branch of the shared min, max or abs helper is not taken: only a call of the spec's own that
    saturates (or, for abs, reads a negative value) takes it, and no run of the suite makes one do so (a counter
    reaches its bound after more steps). A C
    helper (`min_i`, `min_d`) serves the calls of its type only; the Python one (`min`) serves all."""
    fn, _, suffix = helper.partition("_")
    kind = {"i": "int", "d": "real"}.get(suffix)
    types = name_types(machine)
    calls = sorted(
        {
            show(n)
            for e in _expressions(machine)
            for n in nodes(e)
            if isinstance(n, Call) and n.fn == fn and kind in (None, type_of(n, types))
        }
    )
    if not calls:
        return ""
    where = "reads a negative value" if fn == "abs" else "bounds its value"
    return (
        f"the shared {fn} helper takes this branch only where one of the spec's {fn}(...) {where} "
        f"({', '.join(calls)}), which no run of the suite (at most {depth} steps) does; a longer run may "
        "(try --depth)"
    )


def _indent(text: str) -> int:
    return len(text) - len(text.lstrip())


def others_than_chain(lines: Sequence[str], line: int, numbered: Sequence[str]) -> list[str] | None:
    """For a gap in the last branch (`else`) of a variable's update by the transitions `fired == N` names: the
    transitions that take that branch, those the chain does not name (each of whose steps takes its own branch);
    None for a gap elsewhere."""
    k = line - 2  # the line above the gap
    if not 0 <= k < len(lines) or not _ELSE.match(lines[k]):
        return None
    named: set[int] = set()
    for text in reversed(lines[:k]):
        if _indent(text) < _indent(lines[k]):
            break
        if _indent(text) == _indent(lines[k]):
            branch = _FIRED.search(text)
            if branch is None:
                break
            named.add(int(branch.group(1)))
            if text.lstrip().startswith("if "):
                break
    return [t for n, t in enumerate(numbered, 1) if n not in named] if named else None


NO_TRANSITION = (
    "this branch is taken only where no transition fires, which the code never has: each mode's chain ends in a "
    "transition enabled whenever the ones before it are not"
)
OTHERWISE_ONLY = (
    "this branch is taken only where no transition fires, in a mode's otherwise, which no run of the suite reaches"
)


@dataclass(frozen=True)
class Reach:
    """What the suite reaches: its runs' `depth`, the modes no run is in (`unvisited`) and those whose chain in
    the code ends in a transition enabled whenever the ones before it are not (`closed`: no step of the code
    in them fires none)."""

    depth: int
    unvisited: Collection[str] = ()
    closed: Collection[str] = ()


def _through_others(others: Sequence[str], pairs: Sequence[Pair], *, closed: bool) -> list[str]:
    """The reason of a gap only the transitions `others` (or no transition, unless every mode's chain is
    `closed`) would take: each one's reasons, if each has one."""
    found = [reasons_for(t, pairs) for t in others]
    if not all(found):
        return []
    which = f"one of {', '.join(others)}" if len(others) > 1 else others[0]
    none = "" if closed else " (or no transition does)"
    return [f"this branch is taken when {which} fires{none}", *(r for rs in found for r in rs)]


def _no_transition(machine: Machine, pairs: Sequence[Pair], reach: Reach) -> list[str]:
    """The reason no step of the suite fires no transition: in each mode, its chain closes, no run is in it, or
    the reasons of its last guard (as for its `otherwise` branch); none if a mode has none."""
    found: list[str] = []
    for state in machine.states:
        if state in reach.closed:
            continue
        chain = machine.outgoing(state)
        if state in reach.unvisited:
            mode = [unvisited_reason(state, reach.depth)]
        else:
            mode = reasons_for(chain[-1].id, pairs) if chain else []
        if not mode:
            return []
        found += mode
    return [OTHERWISE_ONLY, *dict.fromkeys(found)] if found else [NO_TRANSITION]


def _readers(name: str, machine: Machine) -> list[str] | None:
    """The definitions and transitions whose expressions read the definition `name`, in the spec's order; None
    when an output, an `every` rule or an invariant reads it too, directly or through a definition (the code
    may compute it there whatever fires)."""
    elsewhere = [o.expr for o in machine.outputs] + [i.expr for i in machine.invariants]
    elsewhere += [v.every for v in machine.variables if v.every is not None]
    if name in read_through(machine, elsewhere):
        return None
    found = [d.name for d in machine.definitions if name in names_of(d.expr)]
    exprs = {t.id: [t.guard, *(u.expr for u in t.updates)] for t in machine.transitions}
    return found + [t for t, es in exprs.items() if any(name in names_of(e) for e in es)]


def _through_readers(element: str, machine: Machine, pairs: Sequence[Pair]) -> list[str]:
    """The reason of a gap in a number's function (a definition with no conditions of its own): the reasons of
    what reads it, the nearest readers that have some (`gap` is computed only where `far` reads it)."""
    readers = _readers(element, machine)
    seen, todo = {element}, readers or []
    while todo:
        found = [r for t in todo for r in reasons_for(t, pairs)]
        if found:
            verb = "reads" if len(todo) == 1 else "read"
            return [f"{element} is computed only where {', '.join(todo)} {verb} it", *found]
        seen.update(todo)
        above = [_readers(t, machine) for t in todo]
        if any(r is None for r in above):
            return []
        todo = [r for rs in above for r in rs or [] if r not in seen]
    return []


def reasons_for(element: str, pairs: Sequence[Pair]) -> list[str]:
    """The reasons of the element's conditions without a pair, the decisions the code evaluates."""
    prefixes = ("guard:", "def:", "valid:", "choice:", "output:", "inv:")
    found: list[str] = []
    for p in pairs:
        d = p.objective.decision
        name = d.id.split(":")[-1].split("#")[0]
        if p.reason and name == element and any(d.id.startswith(x) for x in prefixes):
            found.append(f"{p.objective.label}: {p.reason}")
    return found


def mode_of(lines: Sequence[str], line: int, states: Sequence[str]) -> str | None:
    """The mode whose chain of guards holds the gap's line: the C function of that mode, or the Python case."""
    name = _header_match(lines, line, _MODE_FUNCTION)
    if name in states:
        return name
    if in_function(lines, line, ("step", "_step")):
        return _state_block(lines, line, states)
    if not in_function(lines, line, ("_fired",)):
        return None
    for k in range(line - 1, -1, -1):
        case = _MODE_CASE.search(lines[k])
        if case:
            return case.group(1) if case.group(1) in states else None
        if lines[k].startswith("def "):
            break
    if any("not a state" in lines[k] for k in (line - 2, line - 1) if 0 <= k < len(lines)):
        return None
    return _state_block(lines, line, states)  # C's dispatch to the modes' chains


def _state_block(lines: Sequence[str], line: int, states: Sequence[str]) -> str | None:
    """The mode whose block of a direct step holds the gap's line (the nearest mode test above it): the state
    whose name ends the constant tested, the longest such."""
    for k in range(line - 1, -1, -1):
        case = _STATE_CASE.search(lines[k])
        if case:
            named = [s for s in states if case.group(1).endswith(f"_{s}")]
            return max(named, key=len) if named else None
        if _is_header(lines[k]):
            break
    return None


def _last_guard(lines: Sequence[str], line: int, machine: Machine) -> str | None:
    """The last transition of the mode's chain, for a gap in its `otherwise` branch (taken when that transition's
    guard is false too)."""
    if not any(_OTHERWISE.search(lines[k]) for k in (line - 2, line - 1) if 0 <= k < len(lines)):
        return None
    mode = mode_of(lines, line, machine.states)
    chain = machine.outgoing(mode) if mode is not None else ()
    return chain[-1].id if chain else None


def unvisited_reason(mode: str, depth: int) -> str:
    return (
        f"no run of the suite (at most {depth} steps) is in {mode}, so its guards are never evaluated "
        f"(`mlca-verify check` tells by reach:{mode} whether any run is)"
    )


def explain(gaps: Sequence[Gap], source: str, machine: Machine, pairs: Sequence[Pair], *, reach: Reach) -> list[str]:
    """A reason per gap ("" where none is known: a gap the suite should close)."""
    lines = source.splitlines()
    known = {t.id for t in machine.transitions} | {i.id for i in machine.invariants}
    known |= {d.name for d in machine.definitions} | {v.name for v in machine.variables if v.every is not None}
    known |= {o.name for o in machine.outputs}
    numbered = [t.id for t in machine.transitions]
    numbers = {d.name for d in machine.definitions if d.type != "bool"}
    every_closed = set(machine.states) <= set(reach.closed)
    reasons = []
    for gap in gaps:
        element = element_of(lines, gap.line, known, numbered) or _last_guard(lines, gap.line, machine)
        found = reasons_for(element, pairs) if element else []
        if not found and in_function(lines, gap.line, ("_div",)):
            found = [DIVISION]
        helper = None if found else _header_match(lines, gap.line, _HELPER)
        if helper is not None:
            found = [x for x in (saturation(machine, helper, reach.depth),) if x]
        others = None if found or element is not None else others_than_chain(lines, gap.line, numbered)
        if others:
            found = _through_others(others, pairs, closed=every_closed)
        elif others is not None:
            found = _no_transition(machine, pairs, reach)
        if not found and element and gap.condition is not None:
            found = [x for x in (coupling_reason(machine, element, *gap.condition),) if x]
        if not found and element in numbers:
            found = _through_readers(element, machine, pairs)
        mode = None if found else mode_of(lines, gap.line, machine.states)
        if mode is not None and mode in reach.unvisited:
            found = [unvisited_reason(mode, reach.depth)]
        reasons.append(" | ".join(found))
    return reasons


def fill(gaps: Sequence[Gap], source: str, machine: Machine, pairs: Sequence[Pair], *, reach: Reach) -> None:
    found = explain(gaps, source, machine, pairs, reach=reach)
    for gap, reason in zip(gaps, found, strict=True):
        gap.reason = reason
