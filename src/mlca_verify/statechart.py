"""W3C SCXML of a machine with data: an ECMAScript datamodel holds the params (`p`), the variables (`v`) and the
outputs after the last step (`o`); each definition is a function of the state, the variables, the step's event
data and the params; the `step` event's data holds the step's inputs (booleans) and signal samples (numbers).

Each state lists its transitions in priority order, as SCXML takes the first enabled one in document order
(first-match), each assigning the variables from the firing transition's updates, else their `every`, else
their old values (all read before any is written), then the outputs over the state it enters. Under
`otherwise = "stay"` a last transition without a target or a condition does the same where none is enabled, so
the variables move on in the state. A boolean definition that reads a signal takes its `if_invalid` value when
one of its samples lies outside the signal's range (NaN does: every comparison with it is false). Arithmetic is
ECMAScript's binary64, the generated code's; for a machine whose reals are binary32, each real operation, sample,
param and constant is rounded with `Math.fround`, as the code's `float` rounds it (an int that meets a real
too).

Spec text reaches the document only as escaped XML text and JSON strings: names are read through `["name"]`,
states compared to JSON strings, definitions called by their number.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from fractions import Fraction

from mlca_verify.escape import xml_attribute, xml_comment, xml_markup, xml_text
from mlca_verify.floats import FORMATS
from mlca_verify.model import (
    Arith,
    BinOp,
    Call,
    Cmp,
    Const,
    Expr,
    Ite,
    Machine,
    Neg,
    Not,
    Num,
    Prev,
    StateIn,
    Transition,
    Var,
    name_types,
    show,
    type_of,
)

SEND = "Send one event named 'step' per step, its data an object of "


class Undrawable(ValueError):
    """The machine holds what the format cannot carry; the message names the first such element."""


def number(value: Fraction, reals: str = "binary64", real: bool = False) -> str:
    """A literal ECMAScript reads as the generated code's constant: an int as written, a real the nearest value of
    the machine's format (binary32's written as the binary64 that equals it)."""
    if reals == "binary32" and (real or value.denominator != 1):
        return repr(FORMATS["binary32"].of(value))
    return str(value.numerator) if value.denominator == 1 else repr(float(value))


@dataclass(frozen=True)
class At:
    """Where an expression is evaluated: in a known state (a transition's condition or content: `state`, the
    event's data `_event.data`), or inside a definition's function (`st` and `e`, its arguments)."""

    state: str | None
    event: str = "_event.data"

    def args(self) -> str:
        st = "st" if self.state is None else json.dumps(self.state)
        return f"{st}, v, {self.event}, p"


IN_FUNCTION = At(None, "e")


class Script:
    """ECMAScript text of a machine's expressions over `v` (the variables), the event's data and `p` (the
    params)."""

    def __init__(self, m: Machine) -> None:
        self.m = m
        self.defs = {d.name: k for k, d in enumerate(m.definitions)}
        self.params = {p.name for p in m.params}
        self.variables = {v.name for v in m.variables}
        self.inputs = {i.name for i in m.inputs}
        self.ranges = {s.name: s.range for s in m.signals}
        self.types = name_types(m)
        self.single = m.reals == "binary32"  # each real rounded with Math.fround, as the code's float

    def rounded(self, text: str) -> str:
        """`text` as the code holds it: in binary32 rounded to a float (an int operand of a real too)."""
        return f"Math.fround({text})" if self.single else text

    def operand(self, expr: Expr, real: bool, at: At) -> str:
        """An operand of an operation or a comparison; an int one meeting a real converted as the code does."""
        text = self.js(expr, at)
        return self.rounded(text) if real and type_of(expr, self.types) == "int" else text

    def name(self, name: str, at: At) -> str:
        key = json.dumps(name)
        if name in self.defs:
            return f"d{self.defs[name]}({at.args()})"
        if name in self.params:
            return f"p[{key}]"
        if name in self.variables:
            return f"v[{key}]"
        if name in self.ranges:
            return self.sample(name, at)
        if name in self.inputs:
            return f"{at.event}[{key}]"
        raise Undrawable(f"SCXML is not drawn where a guard, an update or a definition reads the output {name}")

    def valid(self, signal: str, at: At) -> str:
        low, high = self.ranges[signal]
        sample = self.sample(signal, at)
        real = self.types[signal] == "real"
        return f"({sample} >= {number(low, self.m.reals, real)} && {sample} <= {number(high, self.m.reals, real)})"

    def sample(self, signal: str, at: At) -> str:
        text = f"{at.event}[{json.dumps(signal)}]"
        return self.rounded(text) if self.types[signal] == "real" else text

    def js(self, expr: Expr, at: At) -> str:
        if isinstance(expr, Const):
            return "true" if expr.value else "false"
        if isinstance(expr, Num):
            return number(expr.value, self.m.reals, expr.real)
        if isinstance(expr, Var):
            return self.name(expr.name, at)
        if isinstance(expr, StateIn):
            if at.state is not None:
                return "true" if at.state in expr.states else "false"
            return "(" + " || ".join(f"st === {json.dumps(s)}" for s in expr.states) + ")"
        if isinstance(expr, Not):
            return f"!{self.js(expr.arg, at)}"
        if isinstance(expr, Neg):
            return f"(-{self.js(expr.arg, at)})"
        if isinstance(expr, Ite):
            return f"({self.js(expr.cond, at)} ? {self.js(expr.then, at)} : {self.js(expr.other, at)})"
        if isinstance(expr, Call):
            return self.call(expr, at)
        if isinstance(expr, Prev):
            raise Undrawable("SCXML is not drawn where a guard, an update or a definition reads prev()")
        if isinstance(expr, Arith | Cmp):
            op = {"==": "===", "!=": "!=="}.get(expr.op, expr.op)
            real = "real" in (type_of(expr.left, self.types), type_of(expr.right, self.types))
            text = f"({self.operand(expr.left, real, at)} {op} {self.operand(expr.right, real, at)})"
            return self.rounded(text) if isinstance(expr, Arith) and real else text
        assert isinstance(expr, BinOp)
        a, b = self.js(expr.left, at), self.js(expr.right, at)
        return {"and": f"({a} && {b})", "or": f"({a} || {b})", "->": f"(!{a} || {b})", "<->": f"({a} === {b})"}[expr.op]

    def call(self, expr: Call, at: At) -> str:
        if expr.fn == "valid":
            arg = expr.args[0]
            assert isinstance(arg, Var)
            return self.valid(arg.name, at)
        real = type_of(expr, self.types) == "real"
        args = ", ".join(self.operand(a, real, at) for a in expr.args)
        return {"min": f"Math.min({args})", "max": f"Math.max({args})", "abs": f"Math.abs({args})"}[expr.fn]

    def functions(self) -> list[str]:
        """One function per definition, in the order they may read each other."""
        lines = []
        for k, d in enumerate(self.m.definitions):
            body = self.js(d.expr, IN_FUNCTION)
            if d.type == "bool" and d.signals:
                gate = " && ".join(self.valid(s, IN_FUNCTION) for s in d.signals)
                body = f"({gate}) ? {body} : {'true' if d.if_invalid else 'false'}"
            lines.append(f"// {xml_comment(f'{d.name} = {show(d.expr)}')}")
            lines.append(f"function d{k}(st, v, e, p) {{ return {body}; }}")
        return lines

    def moved(self, t: Transition | None, at: At) -> str:
        """The variables after a step that fires `t` (None: no transition), as an object literal."""
        updates = {u.variable: u.expr for u in t.updates} if t is not None else {}
        parts = []
        for var in self.m.variables:
            rule = updates.get(var.name, var.every)
            parts.append(f"{json.dumps(var.name)}: {self.name(var.name, at) if rule is None else self.js(rule, at)}")
        return "({" + ", ".join(parts) + "})"

    def outputs(self, at: At) -> str:
        return "({" + ", ".join(f"{json.dumps(o.name)}: {self.js(o.expr, at)}" for o in self.m.outputs) + "})"


def head(m: Machine, caption: str, sent: str) -> list[str]:
    """The lines of an SCXML document before its first state (and its datamodel): the caption, what each `step`
    event carries (`sent`), and the root element."""
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', f"<!-- {xml_comment(caption)} -->"]
    lines.append(f"<!-- {xml_comment(SEND + sent)} -->")
    if m.semantics != "first-match":
        lines.append("<!-- This machine is nondeterministic; SCXML resolves each choice by document order. -->")
    name, initial = xml_attribute(xml_text(m.name)), xml_attribute(m.initial)
    ns = "http://www.w3.org/2005/07/scxml"
    lines.append(f'<scxml xmlns="{ns}" version="1.0" name={name} initial={initial} datamodel="ecmascript">')
    return lines


def transition_note(t: Transition) -> str:
    """The comment before a transition: its id, its guard as the spec writes it, and its cite."""
    cited = f" ({t.cite})" if t.cite else ""
    return f"    <!-- {xml_comment(f'{t.id}: {show(t.guard)}{cited}')} -->"


def to_scxml_data(m: Machine, caption: str) -> str:
    """The SCXML document of `m`, a machine with data; `caption` is its first comment."""
    script = Script(m)
    functions = script.functions()
    initial_v = (
        "({"
        + ", ".join(f"{json.dumps(v.name)}: {number(v.initial, m.reals, v.type == 'real')}" for v in m.variables)
        + "})"
    )
    params = (
        "({"
        + ", ".join(f"{json.dumps(p.name)}: {number(p.default, m.reals, p.type == 'real')}" for p in m.params)
        + "})"
    )
    carried = ", ".join([*m.input_names, *(s.name for s in m.signals)])
    out = [
        *head(m, caption, f"the inputs (booleans) and samples (numbers): {carried}"),
        "  <datamodel>",
        f'    <data id="p" expr={xml_attribute(params)}/>',
        f'    <data id="v" expr={xml_attribute(initial_v)}/>',
        '    <data id="o" expr="({})"/>',
        "  </datamodel>",
        "  <script>",
        *(f"    {xml_markup(line)}" for line in functions),
        "  </script>",
    ]
    for state in m.states:
        out.append(f"  <state id={xml_attribute(state)}>")
        for t in m.outgoing(state):
            out.append(transition_note(t))
            cond = script.js(t.guard, At(state))
            out.append(f'    <transition event="step" cond={xml_attribute(cond)} target={xml_attribute(t.target)}>')
            out += _step(script, t, state, t.target)
            out.append("    </transition>")
        if m.otherwise == "stay":
            out.append("    <!-- no transition enabled: the state is kept, the variables move on -->")
            out.append('    <transition event="step">')
            out += _step(script, None, state, state)
            out.append("    </transition>")
        out.append("  </state>")
    out.append("</scxml>")
    return "\n".join(out) + "\n"


def _step(script: Script, t: Transition | None, source: str, target: str) -> list[str]:
    """The content of a step: the variables (from the state left), then the outputs (over the state entered)."""
    return [
        f'      <assign location="v" expr={xml_attribute(script.moved(t, At(source)))}/>',
        f'      <assign location="o" expr={xml_attribute(script.outputs(At(target)))}/>',
    ]
