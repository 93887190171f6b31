"""The V2V radio between the AVs of a closed-loop run: what each AV's generated controller sends (its claim outputs)
reaches every other AV through a channel of its own, as a network spec's channels do (spec/v2v/): a message is
lost with a probability (never more than `lost_in_row` in a row on one channel, as a channel's `lost = K`
assumes), read `delay` to `max_delay` steps after it was sent, and now and then read a second time the step
after. The draws come from the run's seed, so a run is reproducible.

Which claim concerns whom is the message's content, not a rule: a claim names the lane it claims and where the
sender is, and a receiver hears it on its left (right) when that lane is the one to its left (right) within
`radius_m` of its own position. What a controller does on hearing a claim is its spec's business.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from mlca_verify.words import count


@dataclass(frozen=True)
class V2V:
    """The channel model of a scenario's `[v2v]` section. `on = false` sends nothing (V2V off)."""

    on: bool = True
    loss: float = 0.0  # probability that a message is lost
    lost_in_row: int = 1  # most messages lost in a row on one channel (the proofs' K); 0: none is lost
    delay: int = 1  # fewest steps from sending to reading
    max_delay: int = 1  # most steps
    duplicate: float = 0.0  # probability that a message read is read again the step after
    radius_m: float = 30.0  # how far along the road a claim concerns another AV


@dataclass(frozen=True)
class Claim:
    """A message: AV `sender` claims lane `lane` of `edge`, being at `pos` along it."""

    sender: str
    edge: str
    lane: int
    pos: float


V2V_COUNTS = ("sent", "lost", "late", "duplicated", "conflicts")  # `Traffic`'s fields, as the database names them


@dataclass
class Traffic:
    """What the radio carried in a run, counted per message and receiver."""

    sent: int = 0
    lost: int = 0
    late: int = 0  # read later than the channel's fewest steps
    duplicated: int = 0
    conflicts: int = 0  # times two AVs began moving into one lane within `radius_m` of each other (see `Moves`)


@dataclass
class Radio:
    """The channels between AVs and the messages in flight on them, each due at a step."""

    model: V2V
    rng: random.Random
    traffic: Traffic = field(default_factory=Traffic)
    in_flight: dict[str, list[tuple[int, Claim]]] = field(default_factory=dict)  # receiver -> (due step, claim)
    lost_runs: dict[tuple[str, str], int] = field(default_factory=dict)  # (sender, receiver) -> lost in a row

    @classmethod
    def seeded(cls, model: V2V, seed: int) -> Radio:
        return cls(model, random.Random(f"v2v:{seed}"))

    def send(self, step: int, claim: Claim, receivers: list[str]) -> None:
        """`claim`, sent at `step`, on its way to every receiver but its sender (in the order given)."""
        m = self.model
        for receiver in receivers:
            if receiver == claim.sender:
                continue
            self.traffic.sent += 1
            link = (claim.sender, receiver)
            if self.rng.random() < m.loss and self.lost_runs.get(link, 0) < m.lost_in_row:
                self.lost_runs[link] = self.lost_runs.get(link, 0) + 1
                self.traffic.lost += 1
                continue
            self.lost_runs[link] = 0
            delay = self.rng.randint(m.delay, m.max_delay)
            self.traffic.late += delay > m.delay
            queue = self.in_flight.setdefault(receiver, [])
            queue.append((step + delay, claim))
            if self.rng.random() < m.duplicate:
                self.traffic.duplicated += 1
                queue.append((step + delay + 1, claim))

    def send_claims(
        self, step: int, sender: str, where: tuple[str, int, float], claims: list[bool], receivers: list[str]
    ) -> None:
        """What a controller's claim outputs (`claims`: of the lane to its left, of the lane to its right) say at
        `step`, from `sender` in lane `where[1]` of edge `where[0]` at `where[2]`, sent to the `receivers` (none
        when the radio is off)."""
        edge, lane, pos = where
        if self.model.on:
            for side, claimed in zip((1, -1), claims, strict=True):
                if claimed:
                    self.send(step, Claim(sender, edge, lane + side, pos), receivers)

    def read(self, step: int, receiver: str) -> list[Claim]:
        """The claims `receiver` reads at `step`, dropped from the channel with those due at a step it did not
        listen (on the ramp, in a junction): a message is read at its step or never."""
        queue = self.in_flight.get(receiver)
        if not queue:
            return []
        due = [claim for at, claim in queue if at == step]
        self.in_flight[receiver] = [(at, claim) for at, claim in queue if at > step]
        return due

    def forget(self, av: str) -> None:
        """AV `av` left the road: nothing more is delivered to it."""
        self.in_flight.pop(av, None)


@dataclass
class Moves:
    """What the protocol is to prevent, watched in traffic: two AVs moving into the same lane near each other at
    the same step (the network specs' "not both into the gap"). Each pair counts once per time it begins."""

    radius_m: float
    now: list[Claim] = field(default_factory=list)  # this step's moves: AV, edge, lane moved into, position
    pairs: set[tuple[str, str]] = field(default_factory=set)  # the pairs in conflict at the step before

    def moving(self, claim: Claim) -> None:
        self.now.append(claim)

    def end_step(self, traffic: Traffic) -> None:
        found = {
            (a.sender, b.sender)
            for k, a in enumerate(self.now)
            for b in self.now[k + 1 :]
            if a.edge == b.edge and a.lane == b.lane and abs(a.pos - b.pos) < self.radius_m
        }
        traffic.conflicts += len(found - self.pairs)
        self.pairs, self.now = found, []


def heard(claims: list[Claim], edge: str, lane: int, pos: float, radius_m: float) -> tuple[bool, bool]:
    """Whether the claims read concern the lane to the left and the lane to the right of an AV in `lane` of `edge`
    at `pos`."""
    near = [c.lane for c in claims if c.edge == edge and abs(c.pos - pos) < radius_m]
    return lane + 1 in near, lane - 1 in near


def traffic_text(t: Traffic, model: V2V) -> str:
    """What the radio carried, in words."""
    if not model.on:
        return "off (no message sent)"
    return (
        f"{count(t.sent, 'message')} sent (one per claim and receiver), {t.lost} lost, {t.late} late (more than "
        f"{count(model.delay, 'step')}), {t.duplicated} read twice; {count(t.conflicts, 'time')} two AVs moved "
        f"into one lane within {model.radius_m:g} m of each other"
    )
