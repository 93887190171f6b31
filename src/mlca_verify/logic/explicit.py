"""The explicit-state engine: a breadth-first search of a machine's configurations, one step per input class.

A configuration is the frame of the symbolic engine with its params fixed: the mode, the variables, the
registers prev() reads, and whether no step has been taken yet (a bounded response's counter is not kept: its
longest run of waiting steps is found over the graph of configurations, `sustained`). From each
configuration the search takes one step per input class (`classes`): the first enabled transition fires,
variables take their updates, registers follow, exactly as `symbolic.System.step` says. Every
step is tested against the search's goals (a state reached, a transition fired, a property that fails): the
first step to meet a goal ends the shortest run that does, and when the search has seen every configuration
a goal never met is proved unreachable.

The search is complete for a machine whose reachable configurations are finite and whose signals are read only
through atoms; its budget of configurations (not of time) decides when it gives up, so a verdict never depends
on the machine's load.
"""

from __future__ import annotations

from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

from mlca_verify.logic.classes import InputClass
from mlca_verify.logic.concrete import Compiler, Env, Eval, NotFinite, Undecidable, Value
from mlca_verify.model import Expr, Machine

# mode, first, variables..., registers... (`first` stays True where no register reads it: the configurations
# before and after a step that differ in it alone step alike, so they are one)
Config = tuple[Value | None, ...]
# A goal's test of one step: the environment before it, after it (None: no transition enabled where the
# machine is undefined, so no step), the transition that fired (-1: none) and the configuration reached.
Test = Callable[[Env, "Env | None", int, "Config | None"], bool]
Edges = list[list[tuple[int, int]]]  # per configuration expanded: (the configuration reached, the class)


@dataclass(frozen=True)
class Counter:
    """A bounded response's counter (see `symbolic.Monitor`): consecutive steps with `assume and not goal`."""

    assume: Eval
    goal: Eval
    bound: Eval


@dataclass
class Step:
    """A compiled machine: per mode, its transitions in priority order (id, guard, updates, target)."""

    machine: Machine
    compiler: Compiler
    transitions: list[list[tuple[int, Eval, tuple[tuple[int, Eval], ...], int]]]
    every: tuple[Eval | None, ...]
    assumptions: tuple[Eval, ...]


def compile_step(machine: Machine, compiler: Compiler, frame_assumptions: Sequence[Expr]) -> Step:
    """The step of `machine`; raises `NotFinite` when a guard, update or assumption cannot be compiled."""
    var_index = compiler.variables
    per_mode: list[list[tuple[int, Eval, tuple[tuple[int, Eval], ...], int]]] = [[] for _ in machine.states]
    for k, t in enumerate(machine.transitions):
        guard = compiler.compile(t.guard)
        updates = tuple(
            (var_index[u.variable], compiler.coerced(u.expr, machine.variables[var_index[u.variable]].type))
            for u in t.updates
        )
        target = compiler.states[t.target]
        for s in machine.states if t.sources is None else t.sources:
            per_mode[compiler.states[s]].append((k, guard, updates, target))
    every = tuple(None if v.every is None else compiler.coerced(v.every, v.type) for v in machine.variables)
    assumptions = tuple(compiler.compile(a) for a in frame_assumptions)
    if compiler.prevs:
        raise NotFinite("prev() in a guard, an update or an assumption")
    return Step(machine, compiler, per_mode, every, assumptions)


@dataclass
class Goal:
    """What a search looks for, and where it first found it: the configuration a step left and its class."""

    name: str
    test: Test
    found: tuple[int, int] | None = None
    witness: bool = False  # a run is expected (a state reached, a transition fired): the first search waits for it


@dataclass
class Labels:
    """The steps the search has taken, each with a bit per label (a predicate on the environment after the step:
    a response's `assume and not goal`), kept as the steps are taken so that no step is taken twice: step `j`
    leaves configuration `at` for `to[j]` under class `classes[j]`, where `start[at] <= j < start[at + 1]`.
    A label whose predicate could not be decided keeps the first reason instead of its bits."""

    tests: Sequence[Callable[[Env], bool]]
    start: array[int] = field(default_factory=lambda: array("l"))
    to: array[int] = field(default_factory=lambda: array("l"))
    classes: array[int] = field(default_factory=lambda: array("l"))
    bits: list[bytearray] = field(default_factory=list)
    undecidable: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.bits = [bytearray() for _ in self.tests]
        self.undecidable = ["" for _ in self.tests]

    def add(self, to: int, cls: int, after: Env) -> None:
        self.to.append(to)
        self.classes.append(cls)
        for k, test in enumerate(self.tests):
            bit = False
            if not self.undecidable[k]:
                try:
                    bit = bool(test(after))
                except Undecidable as exc:
                    self.undecidable[k] = str(exc)
            self.bits[k].append(bit)

    def edges(self, label: int, done: int) -> Edges:
        """The steps between the first `done` configurations after which label `label` holds."""
        if self.undecidable[label]:
            raise Undecidable(self.undecidable[label])
        bits, ends = self.bits[label], [*self.start[1 : done + 1], len(self.to)]
        return [
            [(self.to[j], self.classes[j]) for j in range(self.start[at], ends[at]) if bits[j] and self.to[j] < done]
            for at in range(done)
        ]


@dataclass
class Search:
    """A breadth-first search over configurations, resumable: `run` goes on from where it stopped."""

    step: Step
    classes: Sequence[InputClass]
    registers: Sequence[Eval]
    goals: list[Goal]
    labels: Labels | None = None  # the steps taken, labelled, when some response reads them (`restricted_edges`)
    configs: list[Config] = field(default_factory=list)
    index: dict[Config, int] = field(default_factory=dict)
    parent: list[tuple[int, int]] = field(default_factory=list)
    depth: list[int] = field(default_factory=list)
    done: int = 0  # configurations whose steps have all been taken
    complete: bool = False
    undecidable: str = ""

    def __post_init__(self) -> None:
        m = self.step.machine
        start: Config = (
            self.step.compiler.states[m.initial],
            True,
            *(_initial(v.initial, v.type) for v in m.variables),
            *(None for _ in self.registers),
        )
        self.configs.append(start)
        self.index[start] = 0
        self.parent.append((-1, -1))
        self.depth.append(0)

    @property
    def open(self) -> list[Goal]:
        return [t for t in self.goals if t.found is None]

    def run(self, budget: int, until_found: bool = False) -> None:
        """Take the steps of configurations until `budget` steps have been taken, the search is complete, or
        (with `until_found`) every witness goal is found."""
        try:
            while self.done < len(self.configs):
                if until_found and not any(t.witness for t in self.open):
                    return
                if self.steps() >= budget:
                    return
                self.expand(self.done)
                self.done += 1
            self.complete = True
        except Undecidable as exc:
            self.undecidable = str(exc)

    def expand(self, at: int) -> None:
        config = self.configs[at]
        open_goals = self.open
        if self.labels is not None:
            self.labels.start.append(len(self.labels.to))
        for c, cls in enumerate(self.classes):
            taken = self.take(config, cls)
            if taken is None:
                continue
            before, after, fired, nxt = taken
            for t in open_goals:
                if t.found is None and t.test(before, after, fired, nxt):
                    t.found = (at, c)
            if nxt is not None and nxt not in self.index:
                self.index[nxt] = len(self.configs)
                self.configs.append(nxt)
                self.parent.append((at, c))
                self.depth.append(self.depth[at] + 1)
            if self.labels is not None and after is not None and nxt is not None:
                self.labels.add(self.index[nxt], c, after)

    def take(
        self, config: Config, cls: InputClass, total: bool = False
    ) -> tuple[Env, Env | None, int, Config | None] | None:
        """One step from `config` under `cls`: None when an assumption forbids it; no environment after it and no
        next configuration when no transition is enabled and the machine is undefined there (unless `total`:
        then the mode stays, as in the symbolic engine's completeness check)."""
        s = self.step
        n_vars, n_regs = len(s.every), len(self.registers)
        mode, first = config[0], config[1]
        variables = config[2 : 2 + n_vars]
        registers = config[2 + n_vars : 2 + n_vars + n_regs]
        before = Env(mode, variables, cls.bools, cls.atoms)  # type: ignore[arg-type]
        if not all(a(before) for a in s.assumptions):
            return None
        fired, target = -1, mode
        updates: tuple[tuple[int, Eval], ...] = ()
        for k, guard, ups, to in s.transitions[mode]:  # type: ignore[index]
            if guard(before):
                fired, target, updates = k, to, ups
                break
        if fired < 0 and s.machine.otherwise == "undefined" and not total:
            return before, None, fired, None
        values = list(variables)
        for k, every in enumerate(s.every):
            if every is not None:
                values[k] = every(before)
        for k, expr in updates:
            values[k] = expr(before)
        post_vars = tuple(values)
        previous = tuple(r(before) for r in self.registers) if first else registers
        after = Env(target, post_vars, cls.bools, cls.atoms, previous)  # type: ignore[arg-type]
        post_regs = tuple(r(after) for r in self.registers)
        return before, after, fired, (target, not self.registers, *post_vars, *post_regs)

    def steps(self) -> int:
        """The steps taken so far (one per class of each configuration expanded)."""
        return self.done * len(self.classes)

    def run_to(self, goal: Goal) -> list[int]:
        """The classes of the shortest run whose last step meets `goal` (found)."""
        assert goal.found is not None
        at, c = goal.found
        return [*self.stem(at), c]

    def stem(self, at: int) -> list[int]:
        """The classes of the shortest run to configuration `at`."""
        classes = []
        while at > 0:
            at, c = self.parent[at]
            classes.append(c)
        return classes[::-1]


def _initial(value: object, kind: str) -> Value:
    assert isinstance(value, Fraction)
    return int(value) if kind == "int" else value


def count_after(c: Counter, after: Env, before: Value | None) -> int | Value:
    """The counter after a step (`symbolic.System.build_step`): one more while waiting, saturating at the bound."""
    assert before is not None
    if c.assume(after) and not c.goal(after):
        bound = c.bound(after)
        more = before + 1
        return bound if more > bound else more
    return 0


def restricted_edges(search: Search, label: int) -> Edges:
    """The steps between expanded configurations after which the search's label `label` holds, as kept when the
    steps were taken (no step is taken again)."""
    assert search.labels is not None
    return search.labels.edges(label, search.done)


def lasso(search: Search, edges: Edges) -> tuple[list[int], int] | None:
    """The shortest run found that reaches a configuration and comes back to it through `edges`, as its classes
    and the step where the loop starts; None when no such loop exists among the configurations expanded."""
    best: tuple[int, int, list[int]] | None = None  # length, entry, the loop's classes
    for entry in sorted(_cyclic(edges), key=lambda s: search.depth[s]):
        if best is not None and search.depth[entry] + 1 >= best[0]:
            break
        loop = _shortest_cycle(edges, entry)
        if loop is not None and (best is None or search.depth[entry] + len(loop) < best[0]):
            best = (search.depth[entry] + len(loop), entry, loop)
    if best is None:
        return None
    _, entry, loop = best
    return search.stem(entry) + loop, search.depth[entry]


def sustained(search: Search, edges: Edges, steps: int) -> list[int] | None:
    """The shortest run that ends with `steps` steps in a row along `edges` (a bounded response's waiting steps),
    as its classes; None when no configuration starts that many. A loop of edges starts any number."""
    longest = _longest(edges)
    starts = [s for s in range(len(edges)) if longest[s] >= steps]
    if not starts:
        return None
    at = min(starts, key=lambda s: (search.depth[s], s))
    run = search.stem(at)
    for left in range(steps, 0, -1):
        at, c = next((to, c) for to, c in edges[at] if longest[to] >= left - 1)
        run.append(c)
    return run


def _longest(edges: Edges) -> list[float]:
    """For each node, the most edges a path from it can take (infinite where it reaches a loop): over the
    components in the order Tarjan's algorithm closes them, each after every component it reaches."""
    longest: list[float] = [0.0] * len(edges)
    for component in _components(edges):
        looped, members = _looped(edges, component), set(component)
        for node in component:
            outside = [1 + longest[to] for to, _ in edges[node] if to not in members]
            longest[node] = float("inf") if looped else max(outside, default=0.0)
    return longest


def _cyclic(edges: Edges) -> set[int]:
    """The nodes that lie on a cycle."""
    return {node for component in _components(edges) if _looped(edges, component) for node in component}


def _looped(edges: Edges, component: list[int]) -> bool:
    """Does a strongly connected component hold a cycle (more than one node, or a node with a step to itself)?"""
    return len(component) > 1 or any(to == component[0] for to, _ in edges[component[0]])


def _components(edges: Edges) -> list[list[int]]:
    """The strongly connected components (Tarjan's algorithm, without recursion), each closed after every one it
    reaches."""
    index: dict[int, int] = {}
    low: dict[int, int] = {}
    stack: list[int] = []
    on: set[int] = set()
    found: list[list[int]] = []
    for root in range(len(edges)):
        if root in index:
            continue
        work = [(root, 0)]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            node, k = work[-1]
            if k < len(edges[node]):
                work[-1] = (node, k + 1)
                succ = edges[node][k][0]
                if succ not in index:
                    index[succ] = low[succ] = len(index)
                    stack.append(succ)
                    on.add(succ)
                    work.append((succ, 0))
                elif succ in on:
                    low[node] = min(low[node], index[succ])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on.discard(top)
                    component.append(top)
                    if top == node:
                        break
                found.append(component)
    return found


def _shortest_cycle(edges: list[list[tuple[int, int]]], entry: int) -> list[int] | None:
    """The classes of the shortest cycle from `entry` back to it (breadth first)."""
    came: dict[int, tuple[int, int]] = {}
    frontier = [entry]
    while frontier:
        nxt = []
        for node in frontier:
            for to, c in edges[node]:
                if to == entry:
                    return _unwind(came, entry, node, c)
                if to not in came:
                    came[to] = (node, c)
                    nxt.append(to)
        frontier = nxt
    return None


def _unwind(came: dict[int, tuple[int, int]], entry: int, last: int, c: int) -> list[int]:
    loop = [c]
    while last != entry:
        last, step = came[last]
        loop.append(step)
    return loop[::-1]
