"""Networks of machine instances: the loader, the flattening into one transition system, the engines' verdicts
against a brute-force explorer of the network that steps each instance on its own, and the report."""

from __future__ import annotations

import itertools
import json
from collections.abc import Callable
from pathlib import Path

import jsonschema
import pytest

from mlca_verify.cli import main
from mlca_verify.logic import check_all
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.replay64 import Binary64
from mlca_verify.network import Channel, Network, immediate_order
from mlca_verify.network_chart import messages
from mlca_verify.network_report import check_network, network_results
from mlca_verify.spec import load_spec
from tests.conftest import ROOT

NETWORKS = ROOT / "tests" / "networks"
CAR = (NETWORKS / "claim_car.toml").read_text(encoding="utf-8")
PAIR = (NETWORKS / "claim_pair.toml").read_text(encoding="utf-8")


def _pair(tmp_path: Path, text: str) -> Path:
    (tmp_path / "claim_car.toml").write_text(CAR, encoding="utf-8")
    path = tmp_path / "pair.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _channels(
    delay: tuple[int, int], lost: tuple[int, int], extra: tuple[str, str] = ("", ""), schedule: str = ""
) -> str:
    """The pair with its two channels' delays, losses and other keys set, and the network's schedule."""
    head, _, rest = PAIR.partition("[[channel]]")
    body = ""
    for (cid, src, dst), d, k, more in zip((("ab", "A", "B"), ("ba", "B", "A")), delay, lost, extra, strict=True):
        body += f'[[channel]]\nid = "{cid}"\nfrom = "{src}.claiming"\nto = "{dst}.other_claims"\n'
        body += f"delay = {d}\nlost = {k}\n{more}\n"
    invariant = rest[rest.index("[[invariant]]") :].replace('expect = "violated"\n', "")
    return head.replace("[network]\n", f"[network]\n{schedule}") + body + invariant


# --- an explorer that shares nothing with the flattening or the solvers -----------------------------

State = tuple[tuple[str, ...], tuple[tuple[bool, ...], ...], tuple[int, ...], tuple[int, ...], tuple[int, ...]]


def explore(net: Network, bad: Callable[[dict[str, str]], bool], depth: int = 12) -> int | None:
    """The fewest steps to a network state where `bad` holds (None: none within `depth`), by breadth-first search
    over every free input, every loss, every message age and every turn the network allows, each instance stepped
    by the code's own arithmetic (`replay64.Binary64`) on its own machine. A state: the modes, what each channel's
    sender held after each step (newest last), messages lost in a row, the age delivered last, and the steps each
    instance has sat out."""
    sims = {i.name: Binary64(i.machine) for i in net.instances}
    n = len(net.instances)
    start: State = (
        tuple(i.machine.initial for i in net.instances),
        tuple(() for _ in net.channels),
        tuple(0 for _ in net.channels),
        tuple(c.latest for c in net.channels),
        tuple(0 for _ in net.instances),
    )
    frontier, seen = [start], {start}
    for step in range(1, depth + 1):
        after = []
        for state in frontier:
            for nxt in _successors(net, sims, state, n):
                if bad(dict(zip((i.name for i in net.instances), nxt[0], strict=True))):
                    return step
                if nxt not in seen:
                    seen.add(nxt)
                    after.append(nxt)
        frontier = after
    return None


def _successors(net: Network, sims: dict[str, Binary64], state: State, n: int) -> list[State]:
    _, _, runs, lasts, idle = state
    ports = {(c.receiver, c.port) for c in net.channels}
    free = [(i.name, p) for i in net.instances for p in i.machine.input_names if (i.name, p) not in ports]
    turns = range(n) if net.schedule == "interleaved" else [None]
    if net.fairness:
        turns = [t for t in turns if all(idle[k] < net.fairness - 1 or k == t for k in range(n))]
    per_channel = []
    for k, c in enumerate(net.channels):
        losses = [False, True] if c.lost and runs[k] < c.lost else [False]
        ages = [a for a in range(c.delay, c.latest + 1) if c.order == "any" or a <= lasts[k] + 1]
        per_channel.append([(lost, age) for lost in losses for age in ages])
    found = []
    for turn in turns:
        for values in itertools.product((False, True), repeat=len(free)):
            for choice in itertools.product(*per_channel):
                heard = dict(zip(free, values, strict=True))
                new_modes = _step_all(net, sims, state, heard, choice, turn)
                found.append(_after(net, sims, state, new_modes, choice, turn))
    return found


def _step_all(net: Network, sims: dict[str, Binary64], state: State, heard: dict[tuple[str, str], bool],
              choice: tuple[tuple[bool, int], ...], turn: int | None) -> tuple[str, ...]:  # fmt: skip
    """Every instance's next mode, senders of immediate channels first: a message of age 0 is what its sender
    holds after this very step."""
    modes, sent = state[0], state[1]
    new = dict(zip((i.name for i in net.instances), modes, strict=True))
    for name in immediate_order(net):
        j = next(k for k, i in enumerate(net.instances) if i.name == name)
        inst = net.instances[j]
        ports = dict(heard)
        for k, (c, (lost, age)) in enumerate(zip(net.channels, choice, strict=True)):
            if c.receiver != name:
                continue
            if age == 0:
                got = not lost and _holds(net, sims, c, new[c.sender])
            else:
                again = not c.duplicate and age == state[3][k] + 1  # the message read the step before
                got = len(sent[k]) >= age and not lost and not again and sent[k][-age]
            ports[(c.receiver, c.port)] = ports.get((c.receiver, c.port), False) or got
        if turn is None or turn == j:
            new[name] = sims[name].step(modes[j], {p: ports[(name, p)] for p in inst.machine.input_names})[0]
    return tuple(new[i.name] for i in net.instances)


def _holds(net: Network, sims: dict[str, Binary64], c: Channel, mode: str) -> bool:
    output = next(o for o in net.instance(c.sender).machine.outputs if o.name == c.output)
    return bool(sims[c.sender].ev(output.expr, {}, mode))


def _after(net: Network, sims: dict[str, Binary64], state: State, new_modes: tuple[str, ...],
           choice: tuple[tuple[bool, int], ...], turn: int | None) -> State:  # fmt: skip
    _, sent, runs, _, idle = state
    outputs = {
        (inst.name, o.name): bool(sims[inst.name].ev(o.expr, {}, mode))
        for inst, mode in zip(net.instances, new_modes, strict=True)
        for o in inst.machine.outputs
    }
    keep = max(1, *(c.latest for c in net.channels))
    return (
        new_modes,
        tuple((*h, outputs[(c.sender, c.output)])[-keep:] for h, c in zip(sent, net.channels, strict=True)),
        tuple(r + 1 if lost else 0 for r, (lost, _) in zip(runs, choice, strict=True)),
        tuple(age for _, age in choice),
        tuple(0 if turn in (None, k) else min(i + 1, max(net.fairness - 1, 0)) for k, i in enumerate(idle)),
    )


def _both_move(modes: dict[str, str]) -> bool:
    return modes["A"] == "MOVE" and modes["B"] == "MOVE"


CONFIGURATIONS = [
    ((1, 1), (0, 0), ("", ""), ""),
    ((1, 1), (1, 0), ("", ""), ""),
    ((1, 1), (1, 1), ("", ""), ""),
    ((2, 1), (0, 0), ("", ""), ""),
    ((2, 2), (0, 0), ("", ""), ""),
    ((1, 3), (2, 0), ("", ""), ""),
    ((1, 1), (0, 0), ("max_delay = 2\n", ""), ""),
    ((1, 1), (0, 0), ("max_delay = 2\n", "max_delay = 3\n"), ""),
    ((1, 1), (0, 0), ('max_delay = 3\norder = "any"\n', 'max_delay = 2\norder = "any"\n'), ""),
    ((1, 2), (1, 0), ("max_delay = 2\n", "max_delay = 3\n"), ""),
    ((1, 1), (0, 0), ("", ""), 'schedule = "interleaved"\n'),
    ((1, 1), (1, 1), ("", ""), 'schedule = "interleaved"\nfairness = 2\n'),
    ((2, 1), (0, 0), ("max_delay = 3\n", ""), 'schedule = "interleaved"\nfairness = 3\n'),
    # immediate: A's claim read by B in the step A makes it (A steps first)
    ((0, 1), (0, 0), ("", ""), ""),
    ((0, 1), (1, 0), ("", ""), ""),
    ((0, 1), (0, 0), ("max_delay = 1\n", ""), ""),
    ((0, 1), (1, 1), ('max_delay = 2\norder = "any"\n', ""), ""),
    ((0, 1), (0, 0), ("", ""), 'schedule = "interleaved"\n'),
    # a late message read at most once: a step that would read the one before again reads nothing
    ((1, 1), (0, 0), ("max_delay = 2\nduplicate = false\n", ""), ""),
    ((1, 1), (0, 0), ("max_delay = 3\nduplicate = false\n", "max_delay = 2\nduplicate = false\n"), ""),
]


@pytest.mark.parametrize(("delay", "lost", "extra", "schedule"), CONFIGURATIONS)
def test_the_engine_agrees_with_a_brute_force_explorer_of_the_network(
    tmp_path: Path, delay: tuple[int, int], lost: tuple[int, int], extra: tuple[str, str], schedule: str
) -> None:
    """For each delay (0: immediate, the sender stepping first), loss, order and schedule of the two channels: the
    engine's verdict on the invariant, and its counterexample's length, are those of an explorer that steps each
    car on its own."""
    loaded = load_spec(_pair(tmp_path, _channels(delay, lost, extra, schedule)), network=True)
    assert loaded.network is not None
    shortest = explore(loaded.network, _both_move)
    result = next(r for r in check_all(loaded.machine) if r.prop == "one-in-the-gap")
    assert result.verdict == ("holds" if shortest is None else "violated"), (delay, lost, extra, schedule, shortest)
    if shortest is not None:
        assert result.counterexample is not None
        assert len(result.counterexample.steps) == shortest


def test_the_configurations_exercise_both_verdicts(tmp_path: Path) -> None:
    """The explorer's answers over the configurations above are not all alike (the comparison can fail)."""
    answers = set()
    for delay, lost, extra, schedule in CONFIGURATIONS:
        loaded = load_spec(_pair(tmp_path, _channels(delay, lost, extra, schedule)), network=True)
        assert loaded.network is not None
        answers.add(explore(loaded.network, _both_move))
    assert None in answers and len(answers) >= 3, answers


def test_losses_and_delays_decide_the_verdict(tmp_path: Path) -> None:
    """Reliable channels a step late keep the cars apart; one lost claim each, or a claim two steps late, does not."""
    verdicts = {}
    for delay, lost in (((1, 1), (0, 0)), ((1, 1), (1, 1)), ((2, 2), (0, 0)), ((1, 1), (1, 0))):
        loaded = load_spec(_pair(tmp_path, _channels(delay, lost)), network=True)
        verdicts[(delay, lost)] = next(r.verdict for r in check_all(loaded.machine) if r.prop == "one-in-the-gap")
    assert verdicts == {
        ((1, 1), (0, 0)): "holds",
        ((1, 1), (1, 1)): "violated",
        ((2, 2), (0, 0)): "violated",
        ((1, 1), (1, 0)): "holds",  # B always hears A's claim... and A B's: A yields whenever B claims
    }


def test_the_report_tells_the_counterexample_in_the_networks_words(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["check", str(NETWORKS / "claim_pair.toml")]) == 0
    out = capsys.readouterr().out
    assert "ab: A.claiming reaches B.other_claims the next step; at most 1 lost in a row (input ab~lost)" in out
    rows = [line.split() for line in out.splitlines() if line.strip().startswith(("1 ", "2 "))]
    assert rows[0][1:3] == ["A:KEEP", "B:KEEP"] and rows[0][-4:] == ["A.claim", "B.claim", "A:CLAIM", "B:CLAIM"]
    assert rows[1][1:3] == ["A:CLAIM", "B:CLAIM"] and rows[1][-4:] == ["A.move", "B.move", "A:MOVE", "B:MOVE"]
    assert rows[1][7:9] == ["1", "1"]  # both claims lost
    assert "~fired" not in out and "determinism" not in out and "reach:" not in out
    assert out.rstrip().endswith("1 property: 0 hold, 1 violated, 0 unknown; all as expected")
    chart = out[out.index("message sequence") :].splitlines()[1:7]
    assert [line.split() for line in chart] == [
        ["step", "A", "B"],
        ["----", "-" * 22, "-" * 22],
        ["1", "KEEP", "->", "CLAIM", "KEEP", "->", "CLAIM"],
        ["|--", "ab", "--------------->", "lost", "at", "step", "2"],
        ["<---------------", "ba", "--|", "lost", "at", "step", "2"],
        ["2", "CLAIM", "->", "MOVE", "CLAIM", "->", "MOVE"],
    ]


def test_the_chart_follows_each_message_through_delays_and_losses(tmp_path: Path) -> None:
    """On lossy channels, one read 1 to 3 steps late in any order: every message the chart says was read or lost
    at step j is the one the trace's age at j names, and every loss of a claim in the trace is in the chart."""
    text = _channels((1, 1), (1, 1), ('max_delay = 3\norder = "any"\n', ""))
    loaded = load_spec(_pair(tmp_path, text), network=True)
    net = loaded.network
    assert net is not None
    (result,) = check_network(net, loaded.machine, Limits())
    cx = result.counterexample
    assert result.verdict == "violated" and cx is not None
    found = messages(net, cx)
    assert any(m.lost for m in found)
    for m in found:
        for j in (*m.heard, *m.lost):
            step = cx.steps[j - 1]
            age = int(step.signals["ab~age"]) if m.channel == "ab" else 1
            assert j - age == m.sent and step.inputs[f"{m.channel}~lost"] == (j in m.lost)
    for cid, sender in (("ab", "A"), ("ba", "B")):
        due = {}
        for j, step in enumerate(cx.steps, start=1):
            age = int(step.signals["ab~age"]) if cid == "ab" else 1
            if j - age >= 1 and step.inputs[f"{cid}~lost"] and cx.steps[j - age - 1].outputs[f"{sender}.claiming"]:
                due[j] = j - age
        assert due == {j: m.sent for m in found if m.channel == cid for j in m.lost}


def test_the_report_keeps_the_instances_range_checks_and_drops_the_flat_machines_own() -> None:
    loaded = load_spec(NETWORKS / "claim_pair.toml", network=True)
    assert loaded.network is not None
    flat = check_all(loaded.machine)
    assert {r.prop for r in flat} >= {"determinism", "reach:NETWORK", "range:A.state", "range:ab~run"}
    assert [r.prop for r in network_results(loaded.network, flat)] == ["one-in-the-gap"]


def test_param_overrides_reach_the_instance(tmp_path: Path) -> None:
    (tmp_path / "timer.toml").write_text(
        '[machine]\nname = "T"\ninitial = "A"\nstates = ["A", "B"]\n[inputs]\ngo = { doc = "unused" }\n'
        '[params]\nN = { type = "int", default = 3, range = [1, 10], doc = "steps" }\n'
        '[variables]\nt = { type = "int", initial = 0, range = [0, 10], every = "min(t + 1, 10)", doc = "t" }\n'
        '[outputs]\ndone = { type = "bool", expr = "state == B", doc = "done" }\n'
        '[[transition]]\nfrom = "A"\nto = "B"\nwhen = "t >= N"\n',
        encoding="utf-8",
    )
    net = tmp_path / "net.toml"
    net.write_text(
        '[network]\nname = "N"\n[instances.X]\nspec = "timer.toml"\nparams = { N = 5 }\n'
        '[instances.Y]\nspec = "timer.toml"\n'
        '[[invariant]]\nid = "x-after-y"\nexpr = "X.state == B -> Y.state == B"\n'
        '[[invariant]]\nid = "y-after-x"\nexpr = "Y.state == B -> X.state == B"\nexpect = "violated"\n',
        encoding="utf-8",
    )
    loaded = load_spec(net, network=True)
    assert {p.name: p.default for p in loaded.machine.params} == {"X.N": 5, "Y.N": 3}
    found = {r.prop: r for r in check_all(loaded.machine)}
    assert found["x-after-y"].verdict == "holds"
    cx = found["y-after-x"].counterexample
    assert found["y-after-x"].verdict == "violated" and cx is not None and len(cx.steps) == 4


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("lost = 1", "lost = -1"), "pair.toml:21:8: error: 'lost' must be from 0 to 100 messages in a row, got -1"),
        (('from = "A.claiming"', 'from = "C.claiming"'), "pair.toml:19:8: error: 'C.claiming' must be"),
        (('from = "A.claiming"', 'from = "A.want"'), "pair.toml:19:8: error: 'A.want' is not an output (Car's"),
        (
            ("lost = 1", 'lost = 1\norder = "lifo"'),
            "pair.toml:22:9: error: 'order' must be one of fifo, any, got 'lifo'",
        ),
        (
            ("lost = 1", 'lost = 1\nmax_delay = 2\norder = "any"\nduplicate = false'),
            "pair.toml:24:13: error: 'duplicate = false' needs order = \"fifo\"",
        ),
        (("A.state == MOVE and", "A.state == MOVED and"), "pair.toml:33:25: error: unknown state 'A.MOVED'"),
        (("B.state == MOVE)", "B.speed > 1)"), "pair.toml:33:34: error: unknown name 'B.speed' in invariant"),
        (('spec = "claim_car.toml"', 'spec = "nowhere.toml"'), "pair.toml:10:8: error: instance's spec 'nowhere"),
        (
            ("[instances.B]", "[instances.B]\nparams = { T = 1 }"),
            "pair.toml:14:16: error: 'T' is not a param of Car (none)",
        ),
        (
            ("[network]", "[network]\nsteps = 3"),
            "pair.toml:5:9: error: unknown key 'steps' (allowed: cite, doc, fairness, name, schedule, timeout_ms)",
        ),
    ],
)
def test_a_mistake_in_a_network_is_one_line_at_its_place(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: tuple[str, str], message: str
) -> None:
    old, new = change
    assert old in PAIR
    path = _pair(tmp_path, PAIR.replace(old, new, 1))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.replace(str(tmp_path) + "/", "").startswith(message), err


def test_a_network_given_to_a_command_that_takes_a_machine_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["tests", "--out", str(tmp_path / "tests"), str(NETWORKS / "claim_pair.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        "a network spec: every command but `tests` takes it; `tests` takes each instance's machine spec"
    ), err
    assert not (tmp_path / "tests").exists()


def test_gen_of_a_network_generates_each_instances_machine_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three instances of one machine (each with a context of its own, and its params as the instance sets them)
    share its code: `gen` of the network writes it once, as `gen` of the machine does, beside the network's
    message frames."""
    network, machine = ROOT / "spec" / "v2v" / "gap_repaired.toml", ROOT / "spec" / "v2v" / "mlca_t_claim.toml"
    assert main(["gen", "--out", str(tmp_path / "net"), str(network)]) == 0
    assert main(["gen", "--out", str(tmp_path / "machine"), str(machine)]) == 0
    said = capsys.readouterr().out
    assert said.count("wrote") == 9 and said.count("mlca_t_claim_fsm.c") == 2, said
    written = sorted(p.relative_to(tmp_path / "net") for p in (tmp_path / "net").rglob("*") if p.is_file())
    assert [p.as_posix() for p in written] == [
        "c/gaprepaired_frames.c",
        "c/gaprepaired_frames.h",
        "c/mlca_t_claim_fsm.c",
        "c/mlca_t_claim_fsm.h",
        "python/gaprepaired_frames.py",
        "python/mlca_t_claim_fsm.py",
    ]
    for rel in (p for p in written if "_fsm." in p.name):  # byte for byte the machine's own code
        assert (tmp_path / "net" / rel).read_bytes() == (tmp_path / "machine" / rel).read_bytes()


GUIDE_ROWS = {
    "both reliable, a step late": CONFIGURATIONS[0],
    "A to B immediate, B to A a step late": ((0, 1), (0, 0), ("", ""), ""),
    "A to B lossy, B to A reliable": CONFIGURATIONS[1],
    "both lossy (one in a row)": CONFIGURATIONS[2],
    "both two steps late": CONFIGURATIONS[4],
    "both reliable, read 1 to 2 and 1 to 3 steps late": CONFIGURATIONS[7],
    "interleaved, both lossy, fair within 2 steps": CONFIGURATIONS[11],
}


def test_the_networks_guide_tells_what_each_channel_does(tmp_path: Path) -> None:
    """The guide's table of channel semantics is the engine's verdicts (and counterexample lengths)."""
    guide = (ROOT / "docs" / "guides" / "networks.md").read_text(encoding="utf-8")
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in guide.splitlines() if line.startswith("|")]
    rows = {row[0]: row[1] for row in cells if len(row) == 3}
    assert set(GUIDE_ROWS) <= set(rows)
    for label, config in GUIDE_ROWS.items():
        loaded = load_spec(_pair(tmp_path, _channels(*config)), network=True)
        result = next(r for r in check_all(loaded.machine) if r.prop == "one-in-the-gap")
        said = "holds" if result.counterexample is None else f"violated in {len(result.counterexample.steps)} steps"
        assert rows[label] == said, label


def _mesh(lost: int, delay: int) -> str:
    """Three cars, each hearing the other two on its one input (the channels into it heard together)."""
    text = '[network]\nname = "Mesh"\n'
    for car in "ABC":
        text += f'[instances.{car}]\nspec = "claim_car.toml"\n'
    for src, dst in itertools.permutations("ABC", 2):
        text += f'[[channel]]\nid = "{src}{dst}"\nfrom = "{src}.claiming"\nto = "{dst}.other_claims"\n'
        text += f"delay = {delay}\nlost = {lost}\n"
    pairs = " or ".join(f"({a}.state == MOVE and {b}.state == MOVE)" for a, b in itertools.combinations("ABC", 2))
    return text + f'[[invariant]]\nid = "one-in-the-gap"\nexpr = "not ({pairs})"\n'


@pytest.mark.parametrize(("lost", "delay"), [(0, 1), (1, 1), (0, 2)])
def test_three_cars_hearing_each_other_on_one_input_agree_with_the_explorer(
    tmp_path: Path, lost: int, delay: int
) -> None:
    loaded = load_spec(_pair(tmp_path, _mesh(lost, delay)), network=True)
    assert loaded.network is not None

    def two_move(modes: dict[str, str]) -> bool:
        return sum(m == "MOVE" for m in modes.values()) >= 2

    shortest = explore(loaded.network, two_move, depth=8)
    result = next(r for r in check_all(loaded.machine) if r.prop == "one-in-the-gap")
    assert result.verdict == ("holds" if shortest is None else "violated"), (lost, delay, shortest)
    assert shortest is None or (result.counterexample is not None and len(result.counterexample.steps) == shortest)
    assert [a.id for a in loaded.machine.assumptions if a.id.endswith("~hears")] == [
        "B.other_claims~hears", "C.other_claims~hears", "A.other_claims~hears"
    ]  # fmt: skip


def test_the_networks_guide_shows_the_pair_as_it_is() -> None:
    """The guide's network spec is tests/networks/claim_pair.toml, its comments aside."""
    guide = (ROOT / "docs" / "guides" / "networks.md").read_text(encoding="utf-8")
    shown = guide.split("```toml\n", 1)[1].split("```", 1)[0]
    body = "".join(line for line in PAIR.splitlines(keepends=True) if not line.startswith("#")).lstrip("\n")
    assert shown == body


def test_a_response_over_a_network_is_decided_and_its_lasso_told_in_its_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two cars that always yield to each other's claim can yield forever (a lasso of two steps); with the other
    car not wanting the gap, A moves within 4 steps."""
    text = PAIR.split("[[invariant]]")[0].replace("lost = 1\n", "")
    text += '[[liveness]]\nid = "a-moves"\nassume = "A.want"\ngoal = "A.state == MOVE"\nexpect = "violated"\n'
    text += (
        '[[liveness]]\nid = "a-moves-alone"\nassume = "A.want and not B.want"\ngoal = "A.state == MOVE"\nwithin = 4\n'
    )
    assert main(["check", str(_pair(tmp_path, text))]) == 0
    out = capsys.readouterr().out
    assert (
        "a-moves violated: the assumption holds forever and the goal never does: the run loops through A:KEEP B:KEEP"
        in out
    )
    assert "A.claim B.claim" in out and "A.yield B.yield" in out and "(steps 2..3 repeat forever)" in out
    assert "NETWORK" not in out
    assert out.rstrip().endswith("2 properties: 1 hold, 1 violated, 0 unknown; all as expected")


def test_a_networks_json_report_holds_what_it_is_and_its_runs_messages(tmp_path: Path) -> None:
    """`check --json` of a network validates against the shipped schema, names its instances and channels, and
    lists each message of a counterexample with the steps it was read and lost at (the chart's)."""
    out = tmp_path / "check.json"
    assert main(["check", str(NETWORKS / "claim_pair.toml"), "--json", str(out), "--quiet"]) == 0
    doc = json.loads(out.read_text(encoding="utf-8"))
    schema = json.loads((ROOT / "src" / "mlca_verify" / "schemas" / "check-3.schema.json").read_text())
    jsonschema.Draft202012Validator(schema).validate(doc)
    (entry,) = doc["specs"]
    assert [i["name"] for i in entry["network"]["instances"]] == ["A", "B"]
    assert entry["network"]["channels"][0] == {
        "id": "ab", "from": "A.claiming", "to": "B.other_claims", "delay": 1, "max_delay": 1, "order": "fifo",
        "duplicate": True, "lost": 1, "cite": "corpus",
    }  # fmt: skip
    (result,) = entry["results"]
    assert result["counterexample"]["messages"] == [
        {"channel": "ab", "sent": 1, "value": 1, "heard": [], "lost": [2]},
        {"channel": "ba", "sent": 1, "value": 1, "heard": [], "lost": [2]},
    ]
    machine = tmp_path / "machine.json"
    assert main(["check", str(NETWORKS / "claim_car.toml"), "--json", str(machine), "--quiet"]) == 0
    plain = json.loads(machine.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator(schema).validate(plain)
    assert "network" not in plain["specs"][0]
    assert all("messages" not in (r["counterexample"] or {}) for r in plain["specs"][0]["results"])


def test_a_loop_of_immediate_channels_is_refused_at_its_channel(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _pair(tmp_path, _channels((0, 0), (0, 0)))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip().replace(str(tmp_path) + "/", "")
    assert err.startswith("pair.toml:17:3: error: channel 'ab': immediate channels (delay = 0) make a loop among A, B")


def test_traces_of_a_network_include_the_chart_as_svg(tmp_path: Path) -> None:
    """`check --traces DIR` writes the chart of a network's counterexample as SVG beside its CSV and VCD: a
    lifeline per instance, each lost message a dashed line ending in a cross, drawn where it was lost."""
    import xml.etree.ElementTree as ET

    assert main(["check", str(NETWORKS / "claim_pair.toml"), "--quiet", "--traces", str(tmp_path)]) == 0
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".csv", ".svg", ".vcd"]
    svg = ET.parse(tmp_path / "ClaimPair.one-in-the-gap.svg").getroot()
    ns = "{http://www.w3.org/2000/svg}"
    texts = [t.text for t in svg.iter(f"{ns}text")]
    assert {"A", "B", "step 1", "step 2", "KEEP → CLAIM", "CLAIM → MOVE", "ab", "ba"} <= set(texts)
    dashed = [line for line in svg.iter(f"{ns}line") if line.get("stroke-dasharray") == "5,3"]
    crosses = [p for p in svg.iter(f"{ns}path") if p.get("stroke") == "#c00"]
    assert len(dashed) == len(crosses) == 2
    assert {line.get("x2") for line in dashed} == {"218", "281"}  # two thirds of the way to B, and to A


def test_diagram_draws_a_network_and_each_machine_in_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """DOT: a cluster per instance with its machine's states and transitions, a dashed edge per channel between
    clusters with what it carries and its delivery (Graphviz lays it out as SVG); Mermaid: a composite state per
    instance; SCXML: refused in one line."""
    pair = str(NETWORKS / "claim_pair.toml")
    assert main(["diagram", pair]) == 0
    dot = capsys.readouterr().out
    assert dot.count("subgraph ") == 2 and dot.count('-> "A.CLAIM"') == 1 and dot.count('-> "B.CLAIM"') == 1
    channels = [line for line in dot.splitlines() if "ltail=" in line]
    assert len(channels) == 2 and all("style=dashed" in line for line in channels)
    assert 'label="ab: claiming -> other_claims\\n1 step late, at most 1 lost in a row"' in channels[0]
    assert main(["diagram", pair, "--format", "svg", "--out", str(tmp_path / "net.svg")]) == 0
    assert "<svg" in (tmp_path / "net.svg").read_text(encoding="utf-8")
    assert main(["diagram", pair, "--format", "mermaid"]) == 0
    mermaid = capsys.readouterr().out
    assert "    state A {" in mermaid and "        i1_s0 : KEEP" in mermaid
    assert "    A --> B: ab claiming to other_claims, 1 step late, at most 1 lost in a row" in mermaid
    assert main(["diagram", pair, "--format", "scxml"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.endswith("a network has no SCXML form (its channels are not SCXML's): "
                                                        "draw it as dot, svg or mermaid")  # fmt: skip


def _diff(tmp_path: Path, old: str, new: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    (tmp_path / "old").mkdir(exist_ok=True)
    (tmp_path / "new").mkdir(exist_ok=True)
    left, right = _pair(tmp_path / "old", old), _pair(tmp_path / "new", new)
    capsys.readouterr()
    code = main(["diff", str(left), str(right)])
    return code, capsys.readouterr().out


def test_diff_of_two_networks_judges_each_channel_by_the_runs_it_allows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A channel that may lose fewer messages narrows what every verdict assumes (a regression, though the
    verdict is now fixed); the reverse widens it, and the verdict it loses is the regression; a channel that may
    also be later, with no verdict changed, is no regression."""
    lossy, lossless = _channels((1, 1), (1, 1)), _channels((1, 1), (1, 0))
    code, out = _diff(tmp_path, lossy, lossless, capsys)
    assert code == 1 and "one-in-the-gap  violated  holds  fixed" in out
    assert "  channel ba: fewer environments: every guarantee is weaker (a regression)" in out
    assert "    new: B.claiming to A.other_claims, 1 step late; none lost" in out
    assert out.rstrip().endswith("assumptions narrowed: channel ba allow fewer or other environments, so every "
                                 "guarantee is weaker (a regression)")  # fmt: skip
    code, out = _diff(tmp_path, lossless, lossy, capsys)
    assert code == 1 and "  channel ba: more environments: every guarantee is stronger" in out
    assert out.rstrip().endswith("1 regression: one-in-the-gap held before and no longer hold")
    code, out = _diff(tmp_path, lossy, _channels((1, 1), (1, 1), ('max_delay = 2\norder = "any"\n', "")), capsys)
    assert code == 0 and "  channel ab: more environments: every guarantee is stronger" in out, out
    assert "    new: A.claiming to B.other_claims, 1 to 2 steps late, in any order; at most 1 lost in a row" in out
    code, out = _diff(tmp_path, lossy, _channels((2, 1), (1, 1)), capsys)
    assert code == 1 and "  channel ab: other environments, neither fewer nor more (a regression)" in out
    code, out = _diff(tmp_path, lossy, _channels((1, 1), (1, 1), schedule='schedule = "interleaved"\n'), capsys)
    assert code == 1 and "  schedule: other environments, neither fewer nor more (a regression)" in out


def test_diff_of_a_network_and_a_machine_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", str(NETWORKS / "claim_pair.toml"), str(NETWORKS / "claim_car.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("claim_car.toml: error: a machine spec: `diff` compares a network with a network"), err


def test_a_networks_sarif_finding_points_at_the_channels_that_lost_its_messages(tmp_path: Path) -> None:
    sarif = tmp_path / "check.sarif"
    assert main(["check", str(NETWORKS / "claim_pair.toml"), "--quiet", "--sarif", str(sarif)]) == 0
    log = json.loads(sarif.read_text(encoding="utf-8"))
    schema = json.loads((ROOT / "tests" / "schemas" / "sarif-2.1.0-core.schema.json").read_text())
    jsonschema.validate(log, schema, format_checker=jsonschema.FormatChecker())
    (finding,) = log["runs"][0]["results"]
    lines = PAIR.splitlines()
    related = [
        (r["physicalLocation"]["region"]["startLine"], r["message"]["text"]) for r in finding["relatedLocations"]
    ]
    assert [lines[n - 1 : n + 1] for n, _ in related] == [["[[channel]]", 'id = "ab"'], ["[[channel]]", 'id = "ba"']]
    assert [t for _, t in related] == [
        "channel ab: the message sent after step 1 is lost at step 2",
        "channel ba: the message sent after step 1 is lost at step 2",
    ]


def test_conform_of_a_network_checks_each_instances_machine_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """ClaimPair's two instances run one machine: conform of the network is conform of that machine, once."""
    network = NETWORKS / "claim_pair.toml"
    assert main(["gen", "--out", str(tmp_path / "g"), str(network)]) == 0
    args = ["conform", str(network), "--generated", str(tmp_path / "g"), "--only", "compile,exhaustive"]
    assert main([*args, "--json", str(tmp_path / "c.json")]) == 0
    (entry,) = json.loads((tmp_path / "c.json").read_text())["specs"]
    assert entry["path"].endswith("claim_car.toml") and entry["ok"]
    assert [c["name"] for c in entry["checks"]] == ["up-to-date", "compile", "exhaustive"]
