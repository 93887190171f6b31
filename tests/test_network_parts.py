"""A property over some instances of a network is first decided on the part they make (`network.part`), every
other instance abstracted to anything at any step: the part's proofs against a brute-force explorer of the whole
network on random networks of three cars, a verdict the part cannot give decided on the whole, and the part's
own shape."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mlca_verify.errors import SpecError
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Result
from mlca_verify.network import flatten, part
from mlca_verify.network_report import check_network
from mlca_verify.spec import load_spec
from tests.test_network import CAR, explore

NAMES = ("A", "B", "C")
ChannelSpec = tuple[str, str, int, int, int, str]  # sender, receiver, delay, max_delay (0: none), lost, order


def _text(channels: list[ChannelSpec], pair: tuple[str, str], schedule: str) -> str:
    text = f'[network]\nname = "Three"\n{schedule}\n'
    text += "".join(f'[instances.{n}]\nspec = "claim_car.toml"\n' for n in NAMES)
    for k, (src, dst, delay, late, lost, order) in enumerate(channels):
        text += f'[[channel]]\nid = "c{k}"\nfrom = "{src}.claiming"\nto = "{dst}.other_claims"\ndelay = {delay}\n'
        text += f'lost = {lost}\norder = "{order}"\n' + (f"max_delay = {delay + late}\n" if late else "")
    x, y = pair
    return text + f'[[invariant]]\nid = "apart"\nexpr = "not ({x}.state == MOVE and {y}.state == MOVE)"\n'


def _decide(tmp_path: Path, text: str, pair: tuple[str, str]) -> tuple[Result, int | None]:
    (tmp_path / "claim_car.toml").write_text(CAR, encoding="utf-8")
    (tmp_path / "three.toml").write_text(text, encoding="utf-8")
    loaded = load_spec(tmp_path / "three.toml", network=True)
    net = loaded.network
    assert net is not None
    (result,) = check_network(net, loaded.machine, Limits())
    x, y = pair
    return result, explore(net, lambda modes: modes[x] == "MOVE" and modes[y] == "MOVE", depth=7)


channels = st.lists(
    st.tuples(
        st.sampled_from(NAMES), st.sampled_from(NAMES), st.integers(0, 2), st.integers(0, 1), st.integers(0, 1),
        st.sampled_from(("fifo", "any")),
    ).filter(lambda c: c[0] != c[1]),
    min_size=1, max_size=3, unique_by=lambda c: (c[0], c[1]),
)  # fmt: skip
schedules = st.sampled_from(("", 'schedule = "interleaved"', 'schedule = "interleaved"\nfairness = 3'))


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(channels, st.sampled_from((("A", "B"), ("A", "C"), ("B", "C"))), schedules)
def test_a_verdict_decided_on_a_part_is_the_whole_networks(
    tmp_path: Path, chans: list[ChannelSpec], pair: tuple[str, str], schedule: str
) -> None:
    """On a random network of three cars (every channel semantics, immediate ones included, both schedules), a
    property of two of them holds exactly when an explorer of the whole network finds no state that breaks it,
    and a counterexample is as short as the explorer's shortest."""
    try:
        result, shortest = _decide(tmp_path, _text(chans, pair, schedule), pair)
    except SpecError as err:
        assume("make a loop" not in str(err))  # a loop of immediate channels is refused (tests/test_network.py)
        raise
    if shortest is None:
        assert result.verdict == "holds", (chans, pair, schedule, result.detail)
    else:
        assert result.verdict == "violated", (chans, pair, schedule, shortest)
        assert result.counterexample is not None and len(result.counterexample.steps) == shortest


JAMMER = """[machine]
name = "Jammer"
initial = "ON"
states = ["ON"]
[inputs]
unused = { doc = "nothing it reads" }
[outputs]
claiming = { type = "bool", expr = "true", doc = "it claims every gap, always" }
"""


def test_what_the_part_cannot_prove_is_decided_on_the_whole(tmp_path: Path) -> None:
    """Two cars that hear a third that always claims: on their own (the third abstracted to anything, silence
    included) both may move, so the part finds a violation; the whole network proves they never do."""
    (tmp_path / "jammer.toml").write_text(JAMMER, encoding="utf-8")
    text = _text([("B", "A", 1, 0, 0, "fifo"), ("A", "B", 1, 0, 0, "fifo")], ("A", "B"), "")
    text = text.replace('[instances.C]\nspec = "claim_car.toml"', '[instances.C]\nspec = "jammer.toml"')
    text = text.replace("c0", "x").replace(
        'from = "B.claiming"\nto = "A.other_claims"', 'from = "C.claiming"\nto = "A.other_claims"'
    )
    text = text.replace("c1", "y").replace(
        'from = "A.claiming"\nto = "B.other_claims"', 'from = "C.claiming"\nto = "B.other_claims"'
    )
    result, shortest = _decide(tmp_path, text, ("A", "B"))
    assert shortest is None and result.verdict == "holds", result
    assert "alone" not in result.detail
    loaded = load_spec(tmp_path / "three.toml", network=True)
    assert loaded.network is not None
    piece = part(loaded.network, {"A", "B"})
    assert piece.open_ports == ("A.other_claims", "B.other_claims") and piece.channels == ()


def test_a_part_keeps_its_channels_and_opens_the_ports_fed_from_outside(tmp_path: Path) -> None:
    text = _text([("A", "B", 1, 0, 1, "fifo"), ("C", "B", 2, 0, 0, "fifo"), ("B", "C", 1, 0, 0, "fifo")],
                 ("A", "B"), 'schedule = "interleaved"')  # fmt: skip
    (tmp_path / "claim_car.toml").write_text(CAR, encoding="utf-8")
    (tmp_path / "three.toml").write_text(text, encoding="utf-8")
    loaded = load_spec(tmp_path / "three.toml", network=True)
    assert loaded.network is not None
    piece = part(loaded.network, {"A", "B"})
    assert [i.name for i in piece.instances] == ["A", "B"] and [c.id for c in piece.channels] == ["c0"]
    assert piece.open_ports == ("B.other_claims",) and piece.others
    flat = flatten(piece)
    hears = next(a for a in flat.assumptions if a.id == "B.other_claims~hears")
    assert hears.doc.startswith("at least B.other_claims hears (c0)")
    turn = next(s for s in flat.signals if s.name == "~turn")
    assert turn.range == (0, 2)  # A, B, or an instance outside
    whole = flatten(loaded.network)
    assert next(s for s in whole.signals if s.name == "~turn").range == (0, 2)  # A, B, C
