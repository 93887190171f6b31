"""A network of machine instances and the channels between them, as one transition system (pure).

`flatten` turns a network into one `Machine` that every engine decides as it decides a machine: a single state,
each instance's mode an int variable `<instance>.state`, each name of an instance qualified (`A.gap`), and each
channel a few variables, inputs and assumptions of its own (named with a `~`, which no spec name holds):

- the instances step together (`synchronous`), each by its own first-match rule; or (`interleaved`) one at a
  time, the one an int signal `~turn` names, each at least once in every `fairness` steps when that is given;
- a channel carries an output of one instance, read over its context alone (state, variables, params), to a
  boolean input (several channels into one are heard together: their disjunction) or a signal of another
  (one channel). What the sender holds after step k reaches the receiver at step k + `delay` (delay 1: the
  next step; delay 0: step k itself, the sender stepping first), or, with `max_delay`, at any step from
  k + `delay` to k + `max_delay` that the environment chooses (a signal `<channel>~age`): in order (`fifo`:
  never older than the message read the step before, which may be read again) or in any order. Before the
  first message arrives the receiver reads nothing;
- with `lost = K`, any message may be lost, at most K in a row (an `[[assume]]` over a loss input and a
  counter); nothing read is false for a boolean input and an invalid sample (outside its range) for a signal,
  which the receiver's own `if_invalid` rules then handle.

A receiving port stays an input of the flat machine, tied to what the channel delivers by an assumption, so the
receiver's definitions, `valid()` and invalid samples keep their meaning unchanged.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Literal

from mlca_verify.errors import Loc, SpecError
from mlca_verify.model import (
    IN_MEMORY,
    Arith,
    Assumption,
    BinOp,
    Call,
    Cmp,
    Const,
    Definition,
    Expr,
    Input,
    Invariant,
    Ite,
    Liveness,
    Machine,
    Not,
    Num,
    Output,
    Param,
    Signal,
    StateIn,
    Transition,
    Var,
    Variable,
    bodies,
    children,
    names_of,
    reads_context_only,
    substitute,
    with_children,
)

Order = Literal["fifo", "any"]
Schedule = Literal["synchronous", "interleaved"]
ORDERS: tuple[Order, ...] = ("fifo", "any")
SCHEDULES: tuple[Schedule, ...] = ("synchronous", "interleaved")
NETWORK_STATE = "NETWORK"  # the flat machine's one state
MAX_DELAY = 100
MAX_LOST = 100


@dataclass(frozen=True)
class Instance:
    """One copy of a machine, its params overridden (`machine` already holds the overridden defaults)."""

    name: str
    machine: Machine
    spec: str  # the path the network names
    cite: str = ""
    doc: str = ""
    loc: Loc = IN_MEMORY


@dataclass(frozen=True)
class Channel:
    """`sender.output` to `receiver.port`, delivered `delay` steps later (or from `delay` to `max_delay`, in
    order or not), at most `lost` messages lost in a row."""

    id: str
    sender: str
    output: str
    receiver: str
    port: str
    delay: int = 1
    lost: int = 0
    cite: str = ""
    doc: str = ""
    loc: Loc = IN_MEMORY
    max_delay: int | None = None  # at most this many steps late (None: exactly `delay`)
    order: Order = "fifo"
    duplicate: bool = True  # fifo: a late step may read again the message read the step before (else nothing)

    @property
    def latest(self) -> int:
        """The most steps a message may take."""
        return self.delay if self.max_delay is None else self.max_delay


@dataclass(frozen=True)
class Network:
    name: str
    instances: tuple[Instance, ...]
    channels: tuple[Channel, ...]
    invariants: tuple[Invariant, ...] = ()
    liveness: tuple[Liveness, ...] = ()
    cite: str = ""
    doc: str = ""
    loc: Loc = IN_MEMORY
    schedule: Schedule = "synchronous"
    fairness: int = 0  # interleaved: each instance steps at least once in every `fairness` steps (0: no bound)
    timeout_ms: int = 0  # the solver budget its proofs need, as `check --timeout-ms` (0: the command's)
    # A part of a larger network (see `part`): these boolean ports also hear instances outside it, anything at
    # any step, and (interleaved) an instance outside may take a step's turn.
    open_ports: tuple[str, ...] = ()
    others: bool = False

    def instance(self, name: str) -> Instance:
        return next(i for i in self.instances if i.name == name)


def timing(ch: Channel) -> str:
    """When a channel delivers, in words: `1 step late`, `1 to 2 steps late, in order, each read at most once`."""
    if ch.latest == ch.delay:
        return f"{ch.delay} step{'s' if ch.delay != 1 else ''} late"
    order = "in order" if ch.order == "fifo" else "in any order"
    once = "" if ch.duplicate or ch.order != "fifo" else ", each read at most once"
    return f"{ch.delay} to {ch.latest} steps late, {order}{once}"


def losses(ch: Channel) -> str:
    """What a channel may lose, in words: `at most 1 lost in a row`, `none lost`."""
    return f"at most {ch.lost} lost in a row" if ch.lost else "none lost"


def instances_read(*exprs: Expr) -> frozenset[str]:
    """The instances whose names (`A.gap`, `A.state`) the expressions read."""
    return frozenset(n.partition(".")[0] for e in exprs for n in names_of(e) if "." in n)


def part(net: Network, keep: Collection[str]) -> Network:
    """The instances `keep` of `net` and the channels between them, without properties: every other instance is
    abstracted away. A boolean port that a channel from outside feeds also hears anything at any step (an open
    port), a signal port fed from outside reads any sample, and (interleaved) a step may be an outside
    instance's turn. So every run of `net`, restricted to `keep`, is a run of the part (the outside instances'
    messages are some of the "anything"), and a property over `keep` alone that holds on the part holds on
    `net`, whatever the number and the behaviour of the others. A violation on the part may not be one of
    `net`'s."""
    fed = {qualified(c.receiver, c.port) for c in net.channels if c.receiver in keep and c.sender not in keep}
    return replace(
        net,
        instances=tuple(i for i in net.instances if i.name in keep),
        channels=tuple(c for c in net.channels if c.sender in keep and c.receiver in keep),
        invariants=(),
        liveness=(),
        open_ports=tuple(sorted(fed | set(net.open_ports))),
        others=net.others or any(i.name not in keep for i in net.instances),
    )


def qualified(instance: str, name: str) -> str:
    return f"{instance}.{name}"


def mode_of(instance: str) -> str:
    """The flat machine's int variable holding an instance's mode (the index of its state)."""
    return qualified(instance, "state")


# --- one instance ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Renamer:
    """An instance's expressions over the flat machine's names: each name qualified, each state a mode index."""

    instance: str
    states: tuple[str, ...]

    def expr(self, e: Expr) -> Expr:
        if isinstance(e, Var):
            return Var(qualified(self.instance, e.name))
        if isinstance(e, StateIn):
            return in_states(self.instance, self.states, e.states)
        return with_children(e, tuple(self.expr(c) for c in children(e)))

    def name(self, name: str) -> str:
        return qualified(self.instance, name)


def in_states(instance: str, states: tuple[str, ...], chosen: tuple[str, ...]) -> Expr:
    """`<instance>.state` is one of `chosen`, as comparisons of the mode variable with the states' indices."""
    mode = Var(mode_of(instance))
    tests: list[Expr] = [Cmp("==", mode, _int(states.index(s))) for s in dict.fromkeys(chosen)]
    result = tests[0] if tests else Const(False)
    for t in tests[1:]:
        result = BinOp("or", result, t)
    return result


def _int(value: int) -> Num:
    return Num(Fraction(value), False)


def _count_up(name: str, cap: int) -> Expr:
    """`min(name + 1, cap)`: a counter of steps that saturates at `cap`."""
    return Call("min", (Arith("+", Var(name), _int(1)), _int(cap)))


def _ite_chain(cases: Sequence[tuple[Expr, Expr]], otherwise: Expr) -> Expr:
    result = otherwise
    for cond, then in reversed(cases):
        result = Ite(cond, then, result)
    return result


@dataclass
class _Parts:
    """The elements of the flat machine, gathered instance by instance and channel by channel."""

    inputs: list[Input]
    params: list[Param]
    signals: list[Signal]
    variables: list[Variable]
    definitions: list[Definition]
    outputs: list[Output]
    assumptions: list[Assumption]
    heard: dict[str, list[tuple[Channel, Expr]]] = field(default_factory=dict)  # a boolean input: its channels
    after: dict[str, Expr] = field(default_factory=dict)  # each instance's mode and variables after the step


def _instance(inst: Instance, parts: _Parts, turn: Expr | None) -> None:
    """The instance's elements, qualified; with `turn` (interleaved), it steps only where `turn` holds and keeps
    its mode and variables elsewhere."""
    m = inst.machine
    if m.semantics != "first-match" or m.otherwise != "stay":
        raise SpecError(inst.loc, f"instance '{inst.name}': a network steps first-match machines that stay otherwise")
    r = Renamer(inst.name, m.states)
    parts.inputs += [replace(i, name=r.name(i.name)) for i in m.inputs]
    parts.params += [replace(p, name=r.name(p.name)) for p in m.params]
    parts.signals += [replace(s, name=r.name(s.name)) for s in m.signals]
    parts.definitions += [
        replace(d, name=r.name(d.name), expr=r.expr(d.expr), signals=tuple(map(r.name, d.signals)))
        for d in m.definitions
    ]
    fired = qualified(inst.name, "~fired")
    parts.definitions.append(_fired(inst, r, fired, turn))
    fires = {t.id: Cmp("==", Var(fired), _int(k + 1)) for k, t in enumerate(m.transitions)}
    by_target = [(fires[t.id], _int(m.states.index(t.target))) for t in m.transitions]
    mode = Variable(
        mode_of(inst.name), "int", Fraction(m.states.index(m.initial)), (Fraction(0), Fraction(len(m.states) - 1)),
        _ite_chain(by_target, Var(mode_of(inst.name))), (), f"the mode of {inst.name} ({', '.join(m.states)})",
        inst.cite, inst.loc,
    )  # fmt: skip
    parts.variables.append(mode)
    parts.after[mode.name] = mode.every if mode.every is not None else Var(mode.name)
    for v in m.variables:
        keep: Expr = Var(r.name(v.name)) if v.every is None else r.expr(v.every)
        updates = [(fires[t.id], r.expr(u.expr)) for t in m.transitions for u in t.updates if u.variable == v.name]
        every = _ite_chain(updates, keep)
        every = every if turn is None else Ite(turn, every, Var(r.name(v.name)))
        parts.variables.append(replace(v, name=r.name(v.name), every=every))
        parts.after[r.name(v.name)] = every
    parts.outputs += [
        replace(o, name=r.name(o.name), expr=r.expr(o.expr), signals=tuple(map(r.name, o.signals))) for o in m.outputs
    ]
    parts.assumptions += [
        replace(a, id=r.name(a.id), expr=r.expr(a.expr) if turn is None else BinOp("->", turn, r.expr(a.expr)))
        for a in m.assumptions
    ]


def _fired(inst: Instance, r: Renamer, name: str, turn: Expr | None) -> Definition:
    """The transition that fires in an instance (its number in the spec, 0: none), by first match; none where
    it is not its `turn`."""
    m = inst.machine
    cases: list[tuple[Expr, Expr]] = []
    for k, t in enumerate(m.transitions):
        guard = r.expr(t.guard)
        cond = guard if t.sources is None else BinOp("and", in_states(inst.name, m.states, t.sources), guard)
        cases.append((cond, _int(k + 1)))
    chain = _ite_chain(cases, _int(0))
    return Definition(
        name, "int", chain if turn is None else Ite(turn, chain, _int(0)), (), False, (),
        f"the transition of {inst.name} that fires",
        inst.cite, inst.loc,
    )  # fmt: skip


# --- channels ----------------------------------------------------------------------------------------


def _channel(net: Network, ch: Channel, parts: _Parts) -> None:
    sender, receiver = net.instance(ch.sender).machine, net.instance(ch.receiver).machine
    output = next(o for o in sender.outputs if o.name == ch.output)
    if not reads_context_only(output.expr, sender):
        raise SpecError(
            ch.loc,
            f"channel '{ch.id}': output '{ch.sender}.{ch.output}' reads the step's inputs; a channel carries an "
            "output over the sender's context (state, variables, params)",
        )
    renamed = Renamer(ch.sender, sender.states)
    sent = renamed.expr(output.expr)  # what the sender holds, read over its context
    ages = _pipeline(ch, output, sent, parts)  # the message of each age the channel may deliver, by age
    if ch.delay == 0:  # immediate: what the sender holds after this very step
        ages = {0: substitute(renamed.expr(_inlined(output.expr, sender)), parts.after), **ages}
    age: Expr = _int(ch.delay) if ch.latest == ch.delay else _age(ch, parts)
    value = (
        ages[ch.latest]
        if len(ages) == 1
        else _ite_chain([(Cmp("==", age, _int(a)), m) for a, m in ages.items()], ages[ch.latest])
    )
    arrived = _arrived(ch, age, parts)
    if not ch.duplicate and ch.latest > ch.delay:  # a message read the step before is not read again
        arrived = BinOp("and", arrived, Cmp("<=", age, Var(f"{ch.id}~last")))
    port = qualified(ch.receiver, ch.port)
    if any(s.name == ch.port for s in receiver.signals):
        tie = Ite(arrived, Cmp("==", Var(port), value), Not(Call("valid", (Var(port),))))
        parts.assumptions.append(
            Assumption(f"{ch.id}~delivers", tie, f"what channel {ch.id} delivers", ch.cite, ch.loc)
        )
    else:
        parts.heard.setdefault(port, []).append((ch, BinOp("and", arrived, value)))


def _inlined(expr: Expr, m: Machine) -> Expr:
    """`expr` with the definitions and outputs it reads replaced by their expressions, down to the context."""
    found = bodies(m)
    for _ in range(len(found) + 1):  # definitions read only earlier ones: each pass removes a level
        if not names_of(expr) & found.keys():
            return expr
        expr = substitute(expr, found)
    return expr


def immediate_order(net: Network) -> list[str]:
    """The instances in an order where the sender of every immediate channel (delay 0) steps before its
    receiver; a loop of immediate channels has no such order (each instance would read what the other computes
    in the same step) and raises a SpecError at one of its channels."""
    edges = [(c.sender, c.receiver, c) for c in net.channels if c.delay == 0]
    order: list[str] = []
    left = [i.name for i in net.instances]
    while left:
        ready = [n for n in left if not any(r == n and s in left for s, r, _ in edges)]
        if not ready:
            loop = next(c for s, r, c in edges if s in left and r in left)
            raise SpecError(
                loop.loc,
                f"channel '{loop.id}': immediate channels (delay = 0) make a loop among {', '.join(left)}: "
                "each would read what another computes in the same step; give one of them a delay",
            )
        order.append(ready[0])
        left.remove(ready[0])
    return order


def _hear(parts: _Parts, open_ports: Collection[str]) -> None:
    """Each boolean input fed by channels: true when one of them delivers true (several channels into one input
    are heard together, as a radio hears every sender); an open port at least then (it also hears outside)."""
    for port, feeds in parts.heard.items():
        heard = feeds[0][1]
        for _, more in feeds[1:]:
            heard = BinOp("or", heard, more)
        ch = feeds[0][0]
        ids = ", ".join(c.id for c, _ in feeds)
        tie, what = (
            (BinOp("->", heard, Var(port)), "at least")
            if port in open_ports
            else (BinOp("<->", Var(port), heard), "what")
        )
        parts.assumptions.append(Assumption(f"{port}~hears", tie, f"{what} {port} hears ({ids})", ch.cite, ch.loc))


def _pipeline(ch: Channel, output: Output, sent: Expr, parts: _Parts) -> dict[int, Expr]:
    """The messages the channel may deliver now, by age (`delay` to `latest` steps since it was sent): the
    sender's output over its context now is age 1 (sent at the step before); older ones are kept in registers
    that shift them along one a step (a boolean as 0 or 1)."""
    flag = output.type == "bool"
    start = Fraction(0) if flag or output.range is None else min(max(Fraction(0), output.range[0]), output.range[1])
    current: Expr = Ite(sent, _int(1), _int(0)) if flag else sent
    by_age: dict[int, Expr] = {1: current}
    for k in range(1, ch.latest):
        name = f"{ch.id}~sent{k}"
        parts.variables.append(
            Variable(
                name, "int" if flag else output.type, start, (Fraction(0), Fraction(1)) if flag else output.range,
                by_age[k], () if flag else output.unit, f"channel {ch.id}: the message sent {k + 1} steps ago",
                ch.cite, ch.loc,
            )
        )  # fmt: skip
        by_age[k + 1] = Var(name)
    by_age[1] = sent  # read as the sender's output itself
    return {
        a: (Cmp("==", m, _int(1)) if flag and a > 1 else m) for a, m in by_age.items() if ch.delay <= a <= ch.latest
    }


def _age(ch: Channel, parts: _Parts) -> Expr:
    """The age of the message delivered this step, chosen by the environment from `delay` to `latest`: in order
    (`fifo`: never older than the one delivered the step before, which may come again) or in any order."""
    age, last = f"{ch.id}~age", f"{ch.id}~last"
    parts.signals.append(
        Signal(age, "int", (), (Fraction(ch.delay), Fraction(ch.latest)), f"channel {ch.id}: the age of the "
               "message it delivers this step", ch.cite, ch.loc)
    )  # fmt: skip
    rules: list[tuple[str, Expr, str]] = [
        ("ages", Call("valid", (Var(age),)), f"delivers a message {ch.delay} to {ch.latest} steps old")
    ]
    if ch.order == "fifo":
        parts.variables.append(
            Variable(
                last, "int", Fraction(ch.latest), (Fraction(ch.delay), Fraction(ch.latest)), Var(age), (),
                f"channel {ch.id}: the age of the message it delivered the step before", ch.cite, ch.loc,
            )
        )  # fmt: skip
        rules.append(("order", Cmp("<=", Var(age), Arith("+", Var(last), _int(1))), "delivers in order"))
    for rid, expr, doc in rules:
        parts.assumptions.append(Assumption(f"{ch.id}~{rid}", expr, f"channel {ch.id} {doc}", ch.cite, ch.loc))
    return Var(age)


def _arrived(ch: Channel, age: Expr, parts: _Parts) -> Expr:
    """A message arrives this step: the one of that age has been sent (a counter of the steps taken, saturating
    at `latest`) and it is not lost (at most `lost` in a row)."""
    steps = f"{ch.id}~steps"
    parts.variables.append(
        Variable(
            steps, "int", Fraction(0), (Fraction(0), Fraction(ch.latest)),
            _count_up(steps, ch.latest), (),
            f"channel {ch.id}: steps taken, up to its longest delay", ch.cite, ch.loc,
        )
    )  # fmt: skip
    arrived: Expr = Cmp(">=", Var(steps), age)
    if ch.lost == 0:
        return arrived
    lost, run = f"{ch.id}~lost", f"{ch.id}~run"
    parts.inputs.append(Input(lost, f"channel {ch.id} loses this step's message", ch.cite, ch.loc))
    parts.variables.append(
        Variable(
            run, "int", Fraction(0), (Fraction(0), Fraction(ch.lost)),
            Ite(Var(lost), _count_up(run, ch.lost), _int(0)), (),
            f"channel {ch.id}: messages lost in a row", ch.cite, ch.loc,
        )
    )  # fmt: skip
    parts.assumptions.append(
        Assumption(
            f"{ch.id}~loses",
            BinOp("->", Var(lost), Cmp("<", Var(run), _int(ch.lost))),
            f"channel {ch.id} loses at most {ch.lost} in a row",
            ch.cite,
            ch.loc,
        )
    )
    return BinOp("and", arrived, Not(Var(lost)))


# --- the whole ---------------------------------------------------------------------------------------


def flatten(net: Network) -> Machine:
    """The network as one machine (see the module's docstring), with the network's properties."""
    immediate_order(net)
    parts = _Parts([], [], [], [], [], [], [])
    turns = _turns(net, parts)
    for inst, turn in zip(net.instances, turns, strict=True):
        _instance(inst, parts, turn)
    for ch in net.channels:
        _channel(net, ch, parts)
    _hear(parts, net.open_ports)
    no_transitions: tuple[Transition, ...] = ()
    return Machine(
        name=net.name,
        initial=NETWORK_STATE,
        states=(NETWORK_STATE,),
        inputs=tuple(parts.inputs),
        transitions=no_transitions,
        cite=net.cite,
        doc=net.doc,
        invariants=net.invariants,
        liveness=net.liveness,
        loc=net.loc,
        params=tuple(parts.params),
        signals=tuple(parts.signals),
        variables=tuple(parts.variables),
        definitions=tuple(parts.definitions),
        outputs=tuple(parts.outputs),
        assumptions=tuple(parts.assumptions),
        step_s=_step(net),
        data=True,
        reals=net.instances[0].machine.reals if net.instances else "binary64",
    )


def _turns(net: Network, parts: _Parts) -> list[Expr | None]:
    """Synchronous: every instance steps at every step. Interleaved: one instance steps, the one an int signal
    `~turn` names (in a part of a larger network, one more number: an instance outside); with `fairness = F`,
    each steps at least once in every F steps (a counter of the steps it has sat out, and an assumption that it
    steps when the counter reaches F - 1)."""
    if net.schedule == "synchronous":
        return [None for _ in net.instances]
    n = len(net.instances) + (1 if net.others else 0)
    parts.signals.append(
        Signal("~turn", "int", (), (Fraction(0), Fraction(n - 1)), "the instance that steps (by its number)",
               net.cite, net.loc)
    )  # fmt: skip
    parts.assumptions.append(
        Assumption("~turn", Call("valid", (Var("~turn"),)), "one instance steps at a time", net.cite, net.loc)
    )
    turns: list[Expr | None] = []
    for k, inst in enumerate(net.instances):
        turn = Cmp("==", Var("~turn"), _int(k))
        turns.append(turn)
        if net.fairness:
            _fair(inst, turn, net.fairness, parts)
    return turns


def _fair(inst: Instance, turn: Expr, bound: int, parts: _Parts) -> None:
    idle = qualified(inst.name, "~idle")
    parts.variables.append(
        Variable(
            idle, "int", Fraction(0), (Fraction(0), Fraction(bound - 1)),
            Ite(turn, _int(0), _count_up(idle, bound - 1)), (),
            f"steps {inst.name} has sat out", inst.cite, inst.loc,
        )
    )  # fmt: skip
    parts.assumptions.append(
        Assumption(
            f"{inst.name}~fair", BinOp("->", Cmp(">=", Var(idle), _int(bound - 1)), turn),
            f"{inst.name} steps at least once in every {bound} steps", inst.cite, inst.loc,
        )
    )  # fmt: skip


def _step(net: Network) -> Fraction | None:
    steps = {i.machine.step_s for i in net.instances}
    return steps.pop() if len(steps) == 1 else None
