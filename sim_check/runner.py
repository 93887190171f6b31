"""One closed-loop run: SUMO through libsumo, the need, sensing, the generated controller, the runtime monitor,
metrics.

One libsumo simulation per process (libsumo keeps one global simulation); the sweep runs each run in a worker
process. For the generated machines, MOBIL and "without", SUMO's own lane changing is off for the AVs
(laneChangeMode 0): every lane change they make is one the controller commanded, executed by SUMO even where
unsafe, so the controller's own safety is what is measured. For SUMO's models the AV keeps SUMO's defaults.

Every sensed controller (the generated machines and "without") decides on one need (sim_check.need): by default
SUMO's own lane-change model's wish. A boolean machine (MLCA, MLCA-R) gets N, W, L and R from sim_check.sensing;
a machine with data (MLCA-T) gets N, U and the raw signals (sim_check.signals) and decides with its generated code
alone: sim_check holds none of its thresholds.

Counting: a lane change is every change of lane that is not the lane's own continuation into the next edge or
junction, so a change in the step an edge is entered counts; its position is measured from the merge (the start
of the acceleration lane). A generated machine's move is commanded when the machine enters MOVING_LEFT or
MOVING_RIGHT; a command for the same move while the machine stays there (after DWELL_S: the move goes on after one
change, or SUMO has not executed it) is a repeat, counted apart. "Without" commands whenever its need holds,
at most once per DWELL_S, and MOBIL whenever its incentive says so; theirs are commands too.

Besides the paper's metrics, each AV records why it changed lane or did not (the mechanism): the episodes in
which N held, whether the AV changed lane in each or it was never resolved, whether a safe gap towards the
wanted side was seen and not taken (deferred), the time spent in each state of the machine, how often each of
its transitions fired, and (the shadow mode) what the controller did with each wish episode of its need.
"""

from __future__ import annotations

import re
import time
from collections import deque
from pathlib import Path
from typing import Any

from mlca_verify.loading import DEFS_SHIFT, HOLDS, STATE_BITS, fired_in
from sim_check import mobil, ssm
from sim_check.accounting import EMERGENCY_DECEL, Driving, Ledger
from sim_check.controllers import Setup, load_controller, setup_of
from sim_check.need import URGENT_M, Need, middle_goal, sumo_wish
from sim_check.radio import Claim, Moves, Radio, heard
from sim_check.reads import Leader, Reads
from sim_check.run_results import SIDES, AvMetrics, RunResult
from sim_check.scenario import Scenario, build, sumo_command
from sim_check.sensing import Network, sense
from sim_check.signals import signals

DWELL_S = 3.0  # a command is not repeated within this time (SUMO's change is instantaneous)
TRACE_STEPS = 20  # steps of history stored with a monitor violation
SIM_LIMIT_S = 3600.0
SAMPLE_STEPS = 10  # the background traffic's speed is sampled every this many steps
UNSAFE_TEXT = re.compile(r"[^A-Za-z0-9_.-]")
MERGE_EDGE = "acc"  # lane changes are measured from the start of this edge (where a route has it)


class ClosedLoop:
    """The state of one run between steps.

    Its step runs between two SUMO steps, every step of every run, and SUMO's step leaves the caches cold for it:
    each Python call and each object it touches costs there several times what it costs in a warm loop. So a
    step keeps each AV's state in one object (`Driving`), reads through the bound `Reads`, and keeps to a few
    calls per AV: observing it (`drive`), the need, sensing, the machine and its monitor, the mechanism's
    accounting; the rare events (a departure, an arrival, a collision, a min-gap contact, a lane change, a
    command) have their own methods."""

    def __init__(self, sumo: Any, setup: Setup, scenario: Scenario, av_ids: tuple[str, ...], seed: int = 0) -> None:
        self.sumo = sumo
        self.read = Reads(sumo)
        self.network = Network(sumo)
        self.setup = setup
        ctrl = self.ctrl = load_controller(setup.name) if setup.kind == "fsm" else None
        states = ctrl.states if ctrl else ()
        self.states = states
        self.transitions = ctrl.transitions if ctrl else ()
        # a machine deciding on the raw signals: the bits of its answer that say a gap is safe (its definitions L, R)
        flags = ctrl.flags if ctrl else ()
        self.safe_bits = sum(1 << (DEFS_SHIFT + k) for k, name in enumerate(flags) if name in ("L", "R"))
        # the side each state of the machine moves to: +1 left, -1 right, 0 none
        self.sides = tuple(SIDES.get(s, 0) for s in states)
        deciders = {"without": self.decide_sensed, "mobil": self.decide_mobil}
        on_signals = ctrl is not None and bool(ctrl.signals)
        self.decide = self.decide_data if on_signals else self.decide_sensed if ctrl else deciders.get(setup.kind)
        if ctrl is not None and ctrl.claims_at:
            self.decide = self.decide_v2v
        self.radio = Radio.seeded(scenario.v2v, seed)
        self.moves = Moves(scenario.v2v.radius_m)
        self.scenario = scenario
        self.target = scenario.target_lane
        self.sumo_need = scenario.traffic.need == "sumo"
        metrics = {av: AvMetrics(av, sensed=setup.kind in ("fsm", "without")) for av in av_ids}
        self.ledger = Ledger(
            self.read, self.network, metrics, states=states, transitions=self.transitions, dt=scenario.traffic.step_s
        )
        self.metrics = metrics
        self.trail = self.ledger.trail
        self.avs: dict[str, Driving] = {}  # every AV that has departed
        self.driving: list[Driving] = []  # those not yet arrived, in the order of their ids
        self.steps = 0
        self.remaining = len(av_ids)  # the AVs that have not arrived

    def step(self, t: float) -> None:
        read = self.read
        departed = read.departed()
        if departed:
            self.depart(departed, t)
        arrived = read.arrived()
        if arrived:
            self.arrive(arrived, t)
        collisions = read.collisions()
        if collisions:
            self.ledger.collide(collisions)
        speeds = 0.0
        if self.driving:
            for av in self.driving:
                speeds += self.drive(av, t)
            if self.moves.now or self.moves.pairs:
                self.moves.end_step(self.radio.traffic)
        self.steps += 1
        if self.steps % SAMPLE_STEPS == 0:
            self.ledger.sample(self.sumo.edge.getIDList, speeds, len(self.driving))

    def enter(self, vid: str, t: float) -> Driving:
        """Start keeping AV `vid`, departed at `t`."""
        ctrl = self.ctrl
        m = self.metrics[vid]
        m.depart_s = t
        av = self.avs[vid] = Driving(
            vid,
            m,
            ctrl.initial if ctrl else 0,
            [0.0] * len(self.sides),
            deque(maxlen=TRACE_STEPS),
            [0] * (len(self.transitions) + 1),
            ctx=ctrl.context() if ctrl else None,
        )
        self.driving.append(av)
        self.driving.sort(key=lambda d: d.id)
        return av

    def depart(self, departed: Any, t: float) -> None:
        for vid in departed:
            if vid in self.metrics:
                if self.setup.kind != "sumo":
                    self.sumo.vehicle.setLaneChangeMode(vid, 0)
                self.enter(vid, t)

    def arrive(self, arrived: Any, t: float) -> None:
        for vid in arrived:
            av = self.avs.get(vid)
            if av is not None:
                av.m.arrive_s = t
                self.remaining -= 1
                self.driving.remove(av)
                self.radio.forget(vid)
                self.ledger.arrived(av)

    def drive(self, av: Driving, t: float) -> float:
        """One step of one AV: observe it (its metrics), and let its controller decide. Returns its speed."""
        read, m, vid = self.read, av.m, av.id
        edge, lane, pos = read.road(vid), read.lane(vid), read.position(vid)
        lane_id = f"{edge}_{lane}" if edge else ""  # SUMO names a lane <edge>_<index>: no getter more a step
        m.distance_m = read.distance(vid)
        if lane_id != av.lane_id:
            self.moved_on(av, t, lane_id, edge, lane)
        braking = read.acceleration(vid) < -EMERGENCY_DECEL
        if braking and not av.braking:
            m.emergency_brakes += 1
        av.braking = braking
        speed: float = read.speed(vid)
        found = read.leader(vid, 250.0)
        leader: Leader = found if found and found[0] else None
        if leader is not None and speed > 1.0:
            gap = max(leader[1], 0.0) / speed
            if m.min_time_gap_s is None or gap < m.min_time_gap_s:
                m.min_time_gap_s = gap
        # SUMO's default collision criterion, counted beside the physical one: libsumo's gaps already subtract the
        # follower's minGap, so a negative gap to the leader or from the follower ("" where none) is a contact
        ahead = leader[0] if leader is not None and leader[1] < 0.0 else ""
        follower = read.follower(vid, 50.0)
        behind = follower[0] if follower[1] < 0.0 else ""
        if ahead or behind or av.close:
            self.ledger.contacts(av, ahead, behind)
        self.trail.append((vid, edge, lane, pos))
        # lane decisions are made off the ramp (one lane) and outside junctions: tested inline, on the hot path
        if self.decide is not None and edge != "ramp" and edge[:1] != ":":
            self.decide(av, t, (edge, lane, pos), leader=leader, speed=speed)
        return speed

    def moved_on(self, av: Driving, t: float, lane_id: str, edge: str, lane: int) -> None:
        """The AV is on another lane than the step before: a lane change, unless the lane is the old one's
        continuation (into a junction or the next edge); entering the merge edge sets the odometer's zero."""
        if edge == MERGE_EDGE and av.edge != MERGE_EDGE:
            av.merge_m = av.m.distance_m
        side = self.network.change(av.lane_id, lane_id) if av.lane_id else 0
        if side:
            self.ledger.changed(av, t, side)
        av.edge, av.lane, av.lane_id = edge, lane, lane_id

    def need_of(self, av: Driving, where: tuple[str, int, float], leader: Leader) -> Need:
        """The AV's need this step, from the scenario's source (sim_check.need)."""
        edge, lane, pos = where
        urgent_end = self.network.lane_end(edge, lane, pos) < URGENT_M
        if self.sumo_need:
            return sumo_wish(self.read, av.id, urgent_end)
        lanes = self.network.lanes[edge]
        return middle_goal(
            self.read, av.id, (edge, lane), lanes=lanes, target=self.target, leader=leader, urgent_end=urgent_end
        )

    def decide_sensed(
        self,
        av: Driving,
        t: float,
        where: tuple[str, int, float],
        *,
        leader: Leader,
        speed: float,
    ) -> None:
        """A boolean machine decides on N, W, L and R (sim_check.sensing); or, "without algorithm", the AV moves
        wherever the need points."""
        need = self.need_of(av, where, leader)
        self.ledger.wish(av, t, need)
        if self.ctrl is None:
            self.move(av, t, where, need.side)
            self.ledger.track(av, need, False, need.side)
            return
        inputs = sense(self.read, self.network, av.id, where, need, speed=speed)
        side = self.machine(av, t, inputs)
        self.move(av, t, where, side)
        self.ledger.track(av, need, inputs["L"] or inputs["R"], side)

    def decide_data(
        self,
        av: Driving,
        t: float,
        where: tuple[str, int, float],
        *,
        leader: Leader,
        speed: float,
    ) -> None:
        """A machine with data decides on N, U and the raw signals, with its generated code alone."""
        edge, lane, _ = where
        need = self.need_of(av, where, leader)
        self.ledger.wish(av, t, need)
        lanes = self.network.lanes[edge]
        sensed = signals(self.read, av.id, lane, lanes=lanes, speed=speed, side=need.side)
        side, safe = self.data_machine(av, t, need, sensed)
        self.move(av, t, where, side)
        self.ledger.track(av, need, safe, side)

    def decide_v2v(
        self,
        av: Driving,
        t: float,
        where: tuple[str, int, float],
        *,
        leader: Leader,
        speed: float,
    ) -> None:
        """A machine that talks to the other AVs decides on N, U, the raw signals and the claims it reads from the
        radio this step (sim_check.radio), with its generated code alone; what it claims goes out on the radio.
        The harness decides nothing about claims: which lane a claim names is the message's content."""
        assert self.ctrl is not None
        edge, lane, pos = where
        need = self.need_of(av, where, leader)
        self.ledger.wish(av, t, need)
        left, right = heard(self.radio.read(self.steps, av.id), edge, lane, pos, self.scenario.v2v.radius_m)
        sensed = signals(self.read, av.id, lane, lanes=self.network.lanes[edge], speed=speed, side=need.side)
        values = (need.side != 0, left, right, need.urgent, *sensed)
        seen = {"N": values[0], "heard_left": left, "heard_right": right, "U": need.urgent, "signals": sensed}
        packed, outputs = self.machine_step(av, t, values, seen)
        said = [outputs[at] for at in self.ctrl.claims_at]
        self.radio.send_claims(self.steps, av.id, where, said, [d.id for d in self.driving])
        command_at = self.ctrl.command_at
        assert command_at is not None
        side = outputs[command_at]
        if side:
            self.moves.moving(Claim(av.id, edge, lane + side, pos))
        self.move(av, t, where, side)
        self.ledger.track(av, need, bool(packed & self.safe_bits), side)

    def data_machine(self, av: Driving, t: float, need: Need, sensed: tuple[float, ...]) -> tuple[int, bool]:
        """One step of the machine with data and its runtime monitor: the side its command moves to (+1, -1 or 0),
        and whether it saw a safe gap (its L or R)."""
        command_at = self.ctrl.command_at if self.ctrl else None
        assert command_at is not None
        values = (need.side != 0, need.urgent, *sensed)
        packed, outputs = self.machine_step(av, t, values, {"N": values[0], "U": values[1], "signals": sensed})
        return outputs[command_at], bool(packed & self.safe_bits)

    def decide_mobil(
        self,
        av: Driving,
        t: float,
        where: tuple[str, int, float],
        *,
        leader: Leader,
        speed: float,
    ) -> None:
        """MOBIL (sim_check.mobil) decides, where the AV makes lane decisions; the end of the acceleration lane is
        a standing obstacle to it."""
        edge, lane, pos = where
        end = self.network.lane_end(edge, lane, pos)
        lowest = 1 if edge == "acc" and lane > 0 else 0
        lanes = self.network.lanes[edge]
        side = mobil.decide(self.read, av.id, lane, lanes, leader=leader, lane_end=end, lowest=lowest)
        if side:
            self.command(av, t, lane + side, repeat=False)

    def machine(self, av: Driving, t: float, inputs: dict[str, bool]) -> int:
        """One step of a machine on the sensed booleans and its runtime monitor; the side its mode moves to (+1, -1
        or 0)."""
        assert self.ctrl is not None
        self.machine_step(av, t, self.ctrl.values(inputs), inputs)
        return self.sides[av.state]

    def machine_step(
        self, av: Driving, t: float, values: tuple[Any, ...], seen: dict[str, Any]
    ) -> tuple[int, list[Any]]:
        """One step of the generated machine on `values` and its runtime monitor, which the ledger keeps with
        `seen` (the inputs as the trace records them); the answer's packed int and the outputs."""
        ctrl = self.ctrl
        assert ctrl is not None
        old = av.state
        packed, *outputs = ctrl.advance(av.ctx, *values)
        av.state = packed & STATE_BITS
        self.ledger.stepped(av, t, old, seen, fired_in(packed))
        if not packed & HOLDS:
            self.ledger.violation(av, t, ctrl.failing())
        return packed, outputs

    def move(self, av: Driving, t: float, where: tuple[str, int, float], side: int) -> None:
        """The side a controller moves to this step (a generated machine's state, or "without"'s need): a move is
        commanded when the side begins (as soon as DWELL_S has passed since the last command), and again (a
        repeat) while it lasts, at most once per DWELL_S."""
        if not side:
            av.moving = 0
            return
        if side == av.moving and t - av.last_change < DWELL_S:
            return
        if self.command(av, t, where[1] + side, repeat=side == av.moving):
            av.moving = side

    def command(self, av: Driving, t: float, target: int, *, repeat: bool) -> bool:
        """Ask SUMO for a lane change (SUMO's change is instantaneous), at most once per DWELL_S; SUMO's own
        lane-change output names the controller's reason (the vehicle parameter lcReason)."""
        if t - av.last_change < DWELL_S:
            return False
        self.sumo.vehicle.setParameter(av.id, "lcReason", self.reason(av))
        self.sumo.vehicle.changeLane(av.id, target, 1.0)
        av.last_change = t
        av.m.commands += 1
        av.m.repeats += repeat
        return True

    def reason(self, av: Driving) -> str:
        """Why the controller commands a change, as SUMO's lane-change output is to name it after its own reasons
        (hence the leading "|"): the controller, the transition that fired (a generated machine), the need's
        reason; only letters, digits and `_.-` of each (a transition id is spec text, and SUMO writes the value
        into XML as it is)."""
        parts = [self.setup.name]
        if av.last_fired:
            parts.append(self.transitions[av.last_fired - 1])
        if av.episode is not None:
            parts.append(av.episode.reason)
        return "|" + ":".join(UNSAFE_TEXT.sub("", part) for part in parts)


def sumo_args(scenario: Scenario, net: Path, routes: Path, seed: int, options: tuple[str, ...] = ()) -> list[str]:
    return sumo_command(net, routes, "--seed", str(seed), "--step-length", str(scenario.traffic.step_s), *options)


def run_once(
    scenario: Scenario,
    controller: str,
    seed: int,
    work: Path,
    *,
    setup: Setup | None = None,
    limit_s: float = SIM_LIMIT_S,
) -> RunResult:
    """One run, start to finish; raises on a simulator failure (the sweep records it). `setup` replaces the
    controller's registered setup (a benchmark varying SUMO options); a run whose AVs have not all arrived after
    `limit_s` simulated seconds fails."""
    import libsumo

    start = time.perf_counter()
    setup = setup or setup_of(controller)
    built = build(scenario, seed, work, setup.av_type)
    if setup.kind == "fsm":
        load_controller(controller)  # compiled before SUMO starts; cached for the loop
    conflicts = work / f"ssm_{seed}_{scenario.traffic.avs}.xml"
    options = (*setup.options, *ssm.options(built.av_ids, conflicts))
    libsumo.start(sumo_args(scenario, built.net, built.routes, seed, options))
    loop = ClosedLoop(libsumo, setup, scenario, built.av_ids, seed)
    result = RunResult(controller, scenario.traffic.avs, seed)
    read, steps, vehicle_steps = loop.read, 0, 0
    try:
        while True:
            libsumo.simulationStep()
            t = read.time()
            steps += 1
            vehicle_steps += read.vehicle_count()
            loop.step(t)
            if not loop.remaining:
                break
            if t > limit_s:
                result.status, result.reason = "failed", f"AVs had not arrived after {limit_s:.0f} simulated s"
                break
    finally:
        libsumo.close()
    result.sim_steps, result.vehicle_steps = steps, vehicle_steps
    ledger = loop.ledger
    result.collisions = len(ledger.pairs)
    result.bg_mean_speed_ms = ledger.bg_mean_speed_ms()
    result.density_veh_km_lane = ledger.mean_density()
    result.metrics = ledger.finish(list(loop.avs.values()))
    for m, found in zip(result.metrics, ssm.read(conflicts, built.av_ids).values(), strict=True):
        m.ssm_conflicts, m.ssm_min_ttc_s, m.ssm_max_drac, m.ssm_min_pet_s = (
            found.count,
            found.min_ttc_s,
            found.max_drac,
            found.min_pet_s,
        )
    result.violations = ledger.violations
    result.v2v = loop.radio.traffic
    result.trajectory_sha256 = ledger.trajectory_sha256()
    result.wall_s = time.perf_counter() - start
    return result


def run_plain(
    scenario: Scenario, seed: int, work: Path, *, setup: Setup | None = None, limit_s: float = SIM_LIMIT_S
) -> tuple[float, int, int]:
    """The same run with SUMO alone, the floor a closed-loop run is measured against (for the benchmarks): no
    sensing, controller, monitor or metrics; the AVs drive by SUMO's own models under the setup's vType and
    options (LC2013's by default); stepped from Python until every AV has arrived or `limit_s` has passed.
    Returns the wall seconds from SUMO's start, the steps and the vehicle-steps."""
    import libsumo

    setup = setup or setup_of("lc2013")
    built = build(scenario, seed, work, setup.av_type)
    start = time.perf_counter()
    options = (*setup.options, *ssm.options(built.av_ids, work / f"ssm_plain_{seed}.xml"))
    libsumo.start(sumo_args(scenario, built.net, built.routes, seed, options))
    read, waiting, steps, vehicle_steps = Reads(libsumo), set(built.av_ids), 0, 0
    try:
        while waiting and read.time() <= limit_s:
            libsumo.simulationStep()
            steps += 1
            vehicle_steps += read.vehicle_count()
            waiting.difference_update(read.arrived())
    finally:
        libsumo.close()
    return time.perf_counter() - start, steps, vehicle_steps
