"""Sweeps: many runs over worker processes, each with its own libsumo, results committed as each run ends.

A worker that crashes (SUMO aborts the process) or hangs past the timeout is killed and replaced; its run is
recorded as failed with the reason, and the sweep goes on.

Workers die with their sweep, even when it is killed with SIGKILL (on Linux the kernel sends them SIGKILL when it
dies: PR_SET_PDEATHSIG). The sweep's temporary folder is named after its process (pid and start time); a sweep
removes the folders of sweeps that are no longer running."""

from __future__ import annotations

import ctypes
import logging
import multiprocessing as mp
import os
import queue
import re
import shutil
import signal
import socket
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

from mlca_verify.errors import UsageError
from sim_check.db import ResultsDB
from sim_check.leases import Owner
from sim_check.run_results import Job, RunResult
from sim_check.runner import run_once
from sim_check.scenario import Scenario

ProgressHook = Callable[[RunResult], None]  # told of every run that ends

WORK_PREFIX = "mlca-sim-work-"  # then the owner's pid and start time: mlca-sim-work-PID-STARTED-XXXXXXXX
STALE = re.compile(re.escape(WORK_PREFIX) + r"(\d+)-(\d*)-")
PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _die_with(parent: int) -> None:
    """Have the kernel kill this process when `parent` (the sweep) dies, however it dies (Linux). The kernel
    watches the thread that started the worker: a sweep starts its workers from the thread that runs it."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the sweep died before the request was made
        os._exit(1)


def _worker(
    scenario: Scenario, work: Path, jobs: mp.Queue[Job | None], results: mp.Queue[tuple[Job, RunResult]], parent: int
) -> None:
    _die_with(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the sweep's to handle: it stops the workers
    tempfile.tempdir = str(work)  # the worker's own temporary files (the compiled controller) go with its folder,
    os.environ["TMPDIR"] = str(work)  # and the compiler's: a build stopped halfway leaves nothing elsewhere
    while True:
        job = jobs.get()
        if job is None:
            return
        controller, avs, seed = job
        try:
            result = run_once(scenario.with_avs(avs), controller, seed, work)
        except Exception as err:  # a simulator error fails this run, not the sweep
            result = RunResult(controller, avs, seed, status="failed", reason=f"{type(err).__name__}: {err}")
            traceback.print_exc(file=sys.stderr)
        results.put((job, result))


def _retire(slot: Slot) -> None:
    """Kill a broken worker and reap it, and close its job queue (no zombie, pipe or feeder thread is left)."""
    slot.process.kill()
    slot.process.join(timeout=10)
    slot.jobs.close()
    slot.jobs.cancel_join_thread()


@dataclass
class Slot:
    process: BaseProcess
    jobs: mp.Queue[Job | None]
    job: Job | None = None
    since: float = 0.0


def work_folder() -> Path:
    """A new temporary folder for a sweep, named after this process; first, those of dead sweeps go."""
    me = Owner.me()
    for stale in Path(tempfile.gettempdir()).glob(f"{WORK_PREFIX}*"):
        match = STALE.match(stale.name)
        if match and stale.is_dir() and not Owner(me.host, int(match[1]), match[2]).alive():
            shutil.rmtree(stale, ignore_errors=True)
    return Path(tempfile.mkdtemp(prefix=f"{WORK_PREFIX}{me.pid}-{me.started}-"))


class Sweep:
    """Runs over local worker processes. The workers only run; this process stores each result in `database`
    (opened by the caller, who closes it) as it comes."""

    def __init__(self, scenario: Scenario, database: ResultsDB, jobs_n: int, timeout_s: float) -> None:
        self.scenario = scenario
        self.database = database
        self.skipped: list[Job] = []  # runs another writer stored first: not stored again
        self.jobs_n = jobs_n
        self.timeout_s = timeout_s
        self.ctx = mp.get_context("spawn")
        self.results = self.ctx.Queue()
        self.finished_keys: set[Job] = set()
        self.work: Path | None = None  # the workers' network and route files, removed when the sweep ends

    def start_slot(self) -> Slot:
        assert self.work is not None
        jobs = self.ctx.Queue()
        work = Path(tempfile.mkdtemp(prefix="worker-", dir=self.work))
        args = (self.scenario, work, jobs, self.results, os.getpid())
        process = self.ctx.Process(target=_worker, args=args, daemon=True)
        if threading.current_thread() is threading.main_thread():  # the worker starts with Ctrl-C ignored,
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # even while it is still importing
            try:
                process.start()
            finally:
                signal.signal(signal.SIGINT, previous)
        else:
            process.start()
        return Slot(process, jobs)

    def run(self, todo: list[Job], progress: ProgressHook) -> list[RunResult]:
        """Run `todo` and store each result as it comes; the leases of runs left undone are released."""
        self.work = work_folder()
        slots: list[Slot] = []
        try:
            return self._run(todo, progress, slots)
        finally:  # interrupted or not, no worker outlives the sweep (finished ones have exited already)
            for slot in slots:
                slot.process.kill()
                slot.process.join(timeout=10)
            shutil.rmtree(self.work, ignore_errors=True)
            self.work = None
            self.database.release()

    def _run(self, todo: list[Job], progress: ProgressHook, slots: list[Slot]) -> list[RunResult]:
        pending = list(todo)
        slots.extend(self.start_slot() for _ in range(min(self.jobs_n, len(pending))))
        finished: list[RunResult] = []
        while pending or any(s.job for s in slots):
            for slot in slots:
                if slot.job is None and pending:
                    slot.job, slot.since = pending.pop(0), time.monotonic()
                    slot.jobs.put(slot.job)
            self.collect(slots, finished, progress)
            for k, slot in enumerate(slots):
                reason = self.broken(slot)
                if reason:
                    controller, avs, seed = slot.job  # type: ignore[misc]
                    self.finish(RunResult(controller, avs, seed, status="failed", reason=reason), finished, progress)
                    _retire(slot)
                    slots[k] = self.start_slot()
        for slot in slots:
            slot.jobs.put(None)
        for slot in slots:
            slot.process.join(timeout=10)
        return finished

    def broken(self, slot: Slot) -> str:
        if slot.job is None:
            return ""
        if not slot.process.is_alive():
            return f"the simulator process died (exit code {slot.process.exitcode})"
        if time.monotonic() - slot.since > self.timeout_s:
            return f"no result within {self.timeout_s:.0f} s: the simulator hung"
        return ""

    def collect(self, slots: list[Slot], finished: list[RunResult], progress: ProgressHook) -> None:
        try:
            job, result = self.results.get(timeout=0.2)
        except queue.Empty:
            return
        for slot in slots:
            if slot.job == job:
                slot.job = None
        self.finish(result, finished, progress)

    def finish(self, result: RunResult, finished: list[RunResult], progress: ProgressHook) -> None:
        key = (result.controller, result.avs, result.seed)
        if key in self.finished_keys:  # a late answer from a worker already given up on
            return
        self.finished_keys.add(key)
        if not self.database.store(result):
            self.skipped.append(key)
        finished.append(result)
        progress(result)


def _ray_job(scenario: Scenario, job: Job) -> RunResult:
    controller, avs, seed = job
    with tempfile.TemporaryDirectory(prefix="mlca-sim-ray-") as work:
        return run_once(scenario.with_avs(avs), controller, seed, Path(work))


class RaySweep(Sweep):
    """The same sweep on a Ray cluster: one task per run, at most one per cluster CPU in flight, so that a task
    is running from its submission on and the timeout measures the run. Results are stored by this process as
    each task ends, exactly as in a local sweep."""

    def __init__(self, scenario: Scenario, database: ResultsDB, address: str, timeout_s: float) -> None:
        super().__init__(scenario, database, 1, timeout_s)
        try:
            import ray
        except ImportError:
            raise UsageError("error: --ray needs the ray package: pip install 'ray>=2.9'") from None
        self.ray = ray
        host, _, port = address.rpartition(":")
        try:
            socket.create_connection((host or "127.0.0.1", int(port)), timeout=3).close()
        except (OSError, ValueError) as err:
            raise UsageError(f"error: cannot connect to the Ray cluster at {address}: {err}") from None
        try:
            ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as err:
            raise UsageError(f"error: cannot connect to the Ray cluster at {address}: {err}") from None
        resources: dict[str, float] = ray.cluster_resources()  # type: ignore[no-untyped-call]
        self.parallel = max(1, int(resources.get("CPU", 1)))
        self.remote = ray.remote(max_retries=0)(_ray_job)

    def run(self, todo: list[Job], progress: ProgressHook) -> list[RunResult]:
        pending = list(todo)
        flight: dict[Any, tuple[Job, float]] = {}
        finished: list[RunResult] = []
        try:
            while pending or flight:
                while pending and len(flight) < self.parallel:
                    job = pending.pop(0)
                    flight[self.remote.remote(self.scenario, job)] = (job, time.monotonic())
                ready, _ = self.ray.wait(list(flight), num_returns=1, timeout=0.5)
                for ref in ready:
                    job, _ = flight.pop(ref)
                    self.finish(self._result(ref, job), finished, progress)
                for ref, (job, since) in list(flight.items()):
                    if time.monotonic() - since > self.timeout_s:
                        self.ray.cancel(ref, force=True)
                        del flight[ref]
                        reason = f"no result within {self.timeout_s:.0f} s: the simulator hung"
                        self.finish(RunResult(*job, status="failed", reason=reason), finished, progress)
        finally:
            self.ray.shutdown()
            self.database.release()
        return finished

    def _result(self, ref: Any, job: Job) -> RunResult:
        try:
            result: RunResult = self.ray.get(ref)
            return result
        except Exception as err:  # a task or worker that died fails this run only
            reason = f"{type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''}"
            return RunResult(*job, status="failed", reason=reason)
