"""Parts of the realtime loop: deadman ramp, lateness histogram, event folding, priority."""

import gc
import itertools
import math
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest

from lab.protocol import VelocityCommand
from lab.runtime.deadline_stats import (
    ON_TIME_TOLERANCE,
    TICK_KINDS,
    DeadlineStats,
    GcPauses,
    LogHistogram,
)
from lab.runtime.deadman import DEADMAN_RAMP_S, DEADMAN_TIMEOUT_S, Deadman
from lab.runtime.loop import STATS_INTERVAL_TICKS, LoopConfig, SimLoop
from lab.runtime.loop_events import EVENT_INTERVAL_S, EventThrottle
from lab.runtime.scheduling import (
    AUTO_FIFO_MIN_CPUS,
    SLICE_MAX_S,
    SLICE_MIN_S,
    name_os_thread,
    request_fifo,
    request_nice,
    request_slice,
    resolve_sched,
    thread_slice,
)
from lab.world.session import Session, SessionConfig

T = TypeVar("T")


def test_deadman_holds_then_ramps_linearly_to_zero() -> None:
    deadman = Deadman()
    deadman.refresh(VelocityCommand(1.0, -0.5, 0.4), now=10.0)
    assert deadman.update(10.0 + DEADMAN_TIMEOUT_S - 1e-3) is None
    halfway = deadman.update(10.0 + DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S / 2)
    assert halfway == pytest.approx(VelocityCommand(0.5, -0.25, 0.2))
    end = deadman.update(10.0 + DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S + 1e-3)
    assert end == VelocityCommand(0.0, 0.0, 0.0)
    assert deadman.update(20.0) is None  # stopped: nothing more to send


def test_late_ticks_are_told_apart_by_whether_the_tick_before_overran() -> None:
    """A late tick after a tick that ended in time is a late wake-up; after an overrun, not."""
    stats = DeadlineStats(period=1e-3, realtime=True)
    late = 2 * ON_TIME_TOLERANCE * 1e-3
    ticks = [(0.0, False), (late, False), (0.0, True), (late, True), (late, False)]
    for lateness, overrun in ticks:
        stats.record(lateness, work=5e-4, overrun=overrun)
    snapshot = stats.snapshot()
    assert snapshot["on_time_fraction"] == pytest.approx(2 / 5)
    assert snapshot["late_wakeups"] == 1 and snapshot["overruns"] == 2
    assert stats.late_woken.total == 1 and stats.late_pushed.total == 2


def test_deadman_refresh_restarts_the_timeout() -> None:
    deadman = Deadman()
    deadman.refresh(VelocityCommand(1.0), now=0.0)
    deadman.refresh(VelocityCommand(1.0), now=0.4)
    assert deadman.update(0.4 + DEADMAN_TIMEOUT_S - 1e-3) is None
    deadman.refresh(VelocityCommand(), now=1.0)  # an explicit zero needs no decay
    assert deadman.update(5.0) is None


def test_deadman_ramp_updates_are_rate_limited() -> None:
    deadman = Deadman()
    deadman.refresh(VelocityCommand(1.0), now=0.0)
    times = np.arange(DEADMAN_TIMEOUT_S + 1e-4, DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S + 0.01, 1e-3)
    sent = [c for c in (deadman.update(float(t)) for t in times) if c is not None]
    assert 40 <= len(sent) <= 60  # ~every 10 ms over 0.5 s, not every tick
    assert all(a.vx >= b.vx for a, b in itertools.pairwise(sent))
    assert sent[-1].vx == 0.0


def test_histogram_percentiles_within_a_bin_of_numpy() -> None:
    rng = np.random.default_rng(0)
    samples = rng.lognormal(mean=np.log(20e-6), sigma=1.0, size=20000)
    hist = LogHistogram()
    for s in samples:
        hist.record(float(s))
    for p in (50, 99):
        exact = np.percentile(samples, p)
        assert exact <= hist.percentile(p) <= exact * LogHistogram.RATIO**2
    assert hist.max == samples.max()
    assert hist.percentile(100) == samples.max()


def test_histogram_counts_zero_and_huge_values() -> None:
    hist = LogHistogram()
    hist.record(0.0)
    hist.record(1e3)
    assert hist.total == 2
    assert hist.percentile(50) <= LogHistogram.LOW_S
    assert hist.percentile(100) == 1e3


def test_histogram_reads_several_percentiles_at_once_as_one_at_a_time() -> None:
    hist = LogHistogram()
    for s in np.geomspace(1e-6, 1e-2, 1000):
        hist.record(float(s))
    hist.record(LogHistogram.EDGES[200])  # on an edge: in the bin it closes
    assert hist.percentiles(0, 50, 99, 100) == [hist.percentile(p) for p in (0, 50, 99, 100)]
    assert hist.counts[200] >= 1 and hist.percentile(100) == 1e-2


def test_one_histogram_is_refreshed_at_a_time_the_headline_ones_most_often() -> None:
    """A refresh passes over one histogram's bins (the stats tick stays short): the work and
    lateness percentiles within three refreshes, every detail within one round of them."""
    stats = DeadlineStats(period=1e-3, realtime=True)
    stats.record(2e-4, 3e-4, overrun=False, kind="state")
    rounds = len(TICK_KINDS) + 3  # the detail histograms: kinds, late woken/pushed, GC

    def p50(*keys: str) -> float:
        value: object = stats.snapshot()
        for key in keys:
            value = value[key]
        return value["p50"]

    for _ in range(3):
        stats.refresh_percentiles()
    assert 300 <= p50("tick_us") <= 300 * LogHistogram.RATIO
    assert 200 <= p50("lateness_us") <= 200 * LogHistogram.RATIO
    for _ in range(3 * rounds - 3):
        stats.refresh_percentiles()
    assert 300 <= p50("tick_us_by_kind", "state") <= 300 * LogHistogram.RATIO
    assert 200 <= p50("late_lateness_us", "woken") <= 200 * LogHistogram.RATIO


def test_event_throttle_folds_bursts() -> None:
    throttle = EventThrottle()
    assert throttle.take(0.0) == 0
    for _ in range(5):
        throttle.hit()
    assert throttle.take(0.0) == 5
    throttle.hit()
    throttle.hit()
    assert throttle.take(EVENT_INTERVAL_S / 2) == 0  # too soon: kept
    assert throttle.take(EVENT_INTERVAL_S + 0.01) == 2


def test_threads_started_by_the_realtime_loop_do_not_inherit_its_priority() -> None:
    policies: dict[str, int] = {}

    def loop_thread() -> None:
        if not request_fifo():
            return
        policies["loop"] = os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK
        child = threading.Thread(target=lambda: policies.update(child=os.sched_getscheduler(0)))
        child.start()
        child.join()

    thread = threading.Thread(target=loop_thread)
    thread.start()
    thread.join()
    if "loop" not in policies:
        pytest.skip("SCHED_FIFO refused on this machine (no privileges)")
    assert policies == {"loop": os.SCHED_FIFO, "child": os.SCHED_OTHER}
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # the calling thread is untouched


@pytest.mark.parametrize(
    ("requested", "cpus", "policy"),
    [
        ("auto", 2, "other"),  # this project's 2-core machines: never starve the UI and browser
        ("auto", AUTO_FIFO_MIN_CPUS - 1, "other"),
        ("auto", AUTO_FIFO_MIN_CPUS, "fifo"),
        ("fifo", 1, "fifo"),  # asked for explicitly
        ("other", 64, "other"),
    ],
)
def test_auto_scheduling_takes_fifo_only_with_enough_cpus(
    requested: str, cpus: int, policy: str
) -> None:
    assert resolve_sched(requested, cpus) == policy


def test_an_unknown_scheduling_is_rejected_by_name() -> None:
    with pytest.raises(ValueError, match="deadline"):
        resolve_sched("deadline", 8)


def test_a_thread_gives_its_python_name_to_the_os_thread() -> None:
    names: list[str] = []

    def named() -> None:
        name_os_thread()
        names.append(Path(f"/proc/self/task/{threading.get_native_id()}/comm").read_text())

    thread = threading.Thread(target=named, name="command-intake-and-more")
    thread.start()
    thread.join()
    assert names == ["command-intake-\n"]  # the OS keeps 15 bytes


@pytest.mark.parametrize(("sched", "fast"), [("other", False), ("fifo", True)])
def test_the_loop_reports_the_scheduling_in_effect(sched: str, fast: bool) -> None:
    """`loop.sched` in telemetry and info: "other" when asked, and always in fast mode."""
    stop = threading.Event()
    loop = SimLoop(_CountingSession(20, stop), _NoTransport(), LoopConfig(fast=fast, sched=sched))

    def run() -> int:  # in a thread of its own: the loop may set its thread's slice
        loop.run(stop)
        return os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK

    assert _in_a_thread(run) == os.SCHED_OTHER
    assert loop.error is None
    snapshot = loop.stats.snapshot()
    assert snapshot["sched"] == "other" and snapshot["fifo"] is False


def _in_a_thread(function: Callable[[], T]) -> T:
    """Run `function` in a new thread (scheduling calls change the calling thread only)."""
    result = []
    thread = threading.Thread(target=lambda: result.append(function()))
    thread.start()
    thread.join()
    return result[0]


def test_a_slice_is_granted_clamped_and_not_inherited_or_refused_cleanly() -> None:
    """At SCHED_OTHER the loop asks for a short EEVDF slice (Linux >= 6.12, unprivileged): the
    kernel clamps it to SLICE_MIN_S..SLICE_MAX_S; threads it starts get the default slice. On a
    kernel without custom slices it reports None and changes nothing."""

    def ask(seconds: float) -> tuple[float | None, float | None, float | None]:
        before = thread_slice()
        granted = request_slice(seconds)
        children: list[float | None] = []
        child = threading.Thread(target=lambda: children.append(thread_slice()))
        child.start()
        child.join()
        return before, granted, children[0]

    main_before = thread_slice()
    before, granted, child = _in_a_thread(lambda: ask(2e-4))
    if granted is None:
        assert _in_a_thread(thread_slice) == before  # nothing changed
        pytest.skip("no custom EEVDF slices on this kernel")
    assert granted == pytest.approx(2e-4)
    assert child == before  # the default slice, not the loop's
    assert _in_a_thread(lambda: request_slice(1e-6)) == pytest.approx(SLICE_MIN_S)
    assert _in_a_thread(lambda: request_slice(10.0)) == pytest.approx(SLICE_MAX_S)
    assert thread_slice() == main_before  # only the asking threads changed


def test_a_refused_or_fifo_slice_request_reports_none(monkeypatch: pytest.MonkeyPatch) -> None:
    """A refused sched_setattr (or sched_getattr, or an unknown machine) gives None; so does a
    thread at SCHED_FIFO, whose slice the request must not touch."""
    import lab.runtime.scheduling as scheduling

    monkeypatch.setattr(scheduling, "_SYS_SCHED_SETATTR", {})
    assert _in_a_thread(lambda: request_slice(1e-4)) is None
    monkeypatch.setattr(scheduling, "_SYS_SCHED_GETATTR", {})
    assert _in_a_thread(lambda: request_slice(1e-4)) is None
    monkeypatch.undo()

    def fifo_then_slice() -> tuple[bool, float | None]:
        return request_fifo(), request_slice(1e-4)

    fifo, granted = _in_a_thread(fifo_then_slice)
    if not fifo:
        pytest.skip("SCHED_FIFO refused on this machine (no privileges)")
    assert granted is None


def test_the_loop_reports_the_slice_it_was_granted() -> None:
    """A realtime loop at SCHED_OTHER with `slice_s` asks for it and reports it in `slice_us`
    (None where the kernel has no custom slices); it runs with either spin."""
    for spin in ("yield", "busy"):
        config = LoopConfig(rate_hz=2000, sched="other", slice_s=3e-4, spin=spin)
        loop = _run_loop(config, ticks=5)
        assert loop.error is None and loop.stats.ticks >= 5
        assert loop.stats.snapshot()["slice_us"] in (None, pytest.approx(300.0))


def test_an_unknown_spin_is_rejected_by_name() -> None:
    with pytest.raises(ValueError, match="sleepy"):
        SimLoop(_CountingSession(1, threading.Event()), _NoTransport(), LoopConfig(spin="sleepy"))


def test_gc_pauses_are_counted_by_generation_while_installed() -> None:
    pauses = GcPauses()
    pauses.install()
    try:
        gc.collect(2)
        gc.collect(0)
    finally:
        pauses.remove()
    gc.collect(2)  # removed: not counted
    assert pauses.counts[2] == 1 and pauses.counts[0] >= 1
    assert pauses.pauses.total == sum(pauses.counts) and pauses.pauses.max > 0.0
    pauses.remove()  # twice: harmless


def test_a_realtime_loop_freezes_what_exists_while_it_runs_and_unfreezes_at_its_end() -> None:
    """While the realtime loop runs, what existed when it started is in the permanent
    generation: a full collection scans only what came after (docs/reliability.md, "The garbage
    collector"). When it stops, it gives them back to the collector."""
    gc.unfreeze()  # from elsewhere in this process
    scanned_before = len(gc.get_objects())
    seen: list[tuple[int, int]] = []  # (frozen, scanned by a full collection) at each tick

    class Watched(_CountingSession):
        def tick(self) -> None:
            seen.append((gc.get_freeze_count(), len(gc.get_objects())))
            super().tick()

    _run_loop(LoopConfig(rate_hz=2000, sched="other"), ticks=5, session=Watched)
    frozen, scanned = seen[0]
    assert frozen >= scanned_before // 2 and scanned < scanned_before // 10, seen[0]
    assert gc.get_freeze_count() == 0


LEAK_SCRIPT = """
import threading, time
from lab.runtime.loop import LoopConfig, SimLoop
from lab.world.session import Session, SessionConfig

class Quiet:
    def receive(self): return None
    def rejections(self): return (0, "", "")
    def reply(self, request, body): pass
    def publish_telemetry(self, message): pass
    def publish_state(self, message): pass
    def publish_event(self, message): pass

session = Session(SessionConfig(robot="anymal"))
assert session.controller.native_kernel is not None  # the native kernel runs
loop = SimLoop(session, Quiet(), LoopConfig(rate_hz=250, sched="other"))
stop = threading.Event()
thread = threading.Thread(target=loop.run, args=(stop,))
thread.start()
time.sleep(0.5)
stop.set()
thread.join()
assert loop.error is None and loop.stats.ticks > 0, (loop.error, loop.stats.ticks)
"""


def test_a_process_that_ran_a_realtime_loop_exits_without_leaked_native_objects() -> None:
    """A realtime loop over an ANYmal session on the native kernel, started, stopped, then the
    process exits: nanobind lists no leaked instance. (The first session's kernel, plant step
    and server tick are in reference cycles: frozen by the loop and never unfrozen, they
    outlived the last collection and nanobind listed them, with their types and functions.)"""
    pytest.importorskip("lab._kernel")
    run = subprocess.run(
        [sys.executable, "-c", LEAK_SCRIPT], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr[-4000:]
    assert "nanobind: leaked" not in run.stderr, run.stderr[-4000:]


def test_ticks_are_timed_by_kind_and_the_details_reach_the_snapshot() -> None:
    """Each tick's work goes to the histogram of its kind (what it did beside the session's
    tick: a telemetry message takes two ticks to build); each percentile refresh updates one
    detail group in turn, so all appear in time."""
    ticks = 1600
    stop = threading.Event()
    loop = SimLoop(_CountingSession(ticks, stop), _NoTransport(), LoopConfig(fast=True))
    loop.run(stop)
    assert loop.error is None
    counts = {kind: h.total for kind, h in loop.stats.work_by_kind.items()}
    messages = counts["telemetry"] / 2
    assert abs(messages - ticks // 10) <= 1 and abs(counts["state"] - ticks // 16) <= 1
    assert abs(counts["publish"] - messages - counts["state"]) <= 2
    assert counts["stats"] == pytest.approx(ticks / STATS_INTERVAL_TICKS, abs=1)
    assert sum(counts.values()) == loop.stats.ticks
    snapshot = loop.stats.snapshot()
    assert set(snapshot["tick_us_by_kind"]) == set(TICK_KINDS)
    assert set(snapshot["late_lateness_us"]) == {"woken", "pushed"}
    assert "gc_pause_us" in snapshot and len(snapshot["gc_collections"]) == 3


def _nice() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def test_a_granted_nice_holds_with_the_slice_and_is_not_inherited() -> None:
    """The nice value the loop is granted stays when the slice is asked for after it; a thread
    the loop starts runs at nice 0. Raising the priority needs CAP_SYS_NICE: without it the
    request reports None and leaves the thread as it was."""

    def ask() -> tuple[int, int | None, float | None, int, int]:
        before = _nice()
        granted = request_nice(-5)
        sliced = request_slice(2e-4)
        return before, granted, sliced, _nice(), _in_a_thread(_nice)

    main_before = _nice()
    before, granted, sliced, after, child = _in_a_thread(ask)
    if granted is None:
        assert after == before  # refused: nothing changed
        pytest.skip("a raised priority is refused here (no CAP_SYS_NICE)")
    assert granted == -5 and after == -5  # the slice request kept it
    assert sliced is None or sliced == pytest.approx(2e-4)
    assert child == 0
    assert _nice() == main_before  # only the asking thread changed
    assert _in_a_thread(lambda: request_nice(3)) == 3  # lowering it needs no privilege


def test_a_refused_or_fifo_nice_request_reports_none(monkeypatch: pytest.MonkeyPatch) -> None:
    """A refused sched_setattr gives None and changes nothing; so does a SCHED_FIFO thread,
    whose nice the request must not touch."""
    import lab.runtime.scheduling as scheduling

    monkeypatch.setattr(scheduling, "_SYS_SCHED_SETATTR", {})
    before = _in_a_thread(_nice)
    assert _in_a_thread(lambda: (request_nice(4), _nice())) == (None, before)
    monkeypatch.undo()
    fifo, granted = _in_a_thread(lambda: (request_fifo(), request_nice(-5)))
    if not fifo:
        pytest.skip("SCHED_FIFO refused on this machine (no privileges)")
    assert granted is None


@pytest.mark.parametrize("nice", [7, None])
def test_the_loop_reports_the_nice_it_was_granted(nice: int | None) -> None:
    """A realtime loop at SCHED_OTHER asks for `nice` and reports what it was granted (a nice
    above 0 needs no privilege); with None it asks for nothing and reports None."""
    loop = _run_loop(LoopConfig(rate_hz=2000, sched="other", nice=nice), ticks=5)
    assert loop.error is None
    assert loop.stats.snapshot()["nice"] == nice


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--nice", "-30"], "--nice"),
        (["--spin-ms", "1.5"], "--spin-ms"),
        (["--floor-s", "11"], "--floor-s"),
    ],
)
def test_serve_refuses_an_out_of_range_loop_setting_by_name(
    argv: list[str], named: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`lab serve` names the loop setting that is out of range and starts nothing (a spin of
    the whole period, 1 ms at 1 kHz, is allowed; longer is not)."""
    from lab.runtime.serve import serve_main

    assert serve_main(argv) == 2
    assert named in capsys.readouterr().err


def _run_loop(
    config: LoopConfig, ticks: int, session: type["_CountingSession"] | None = None
) -> SimLoop:
    """A loop over a session (a `_CountingSession` or one of its subclasses) that stops it
    after `ticks` ticks, run to its end in a thread."""
    stop = threading.Event()
    loop = SimLoop((session or _CountingSession)(ticks, stop), _NoTransport(), config)
    thread = threading.Thread(target=loop.run, args=(stop,))
    thread.start()
    thread.join()
    return loop


class _CountingSession:
    """Stops the loop after `ticks` ticks; `jobs[k]` lists what the loop did after tick k."""

    def __init__(self, ticks: int, stop: threading.Event) -> None:
        self.ticks, self.stop, self.jobs = ticks, stop, [[]]

    def tick(self) -> None:
        if len(self.jobs) == self.ticks:
            self.stop.set()
        self.jobs.append([])

    def telemetry(self) -> dict:
        self.jobs[-1].append("telemetry")
        return {"t": 0.0}

    def telemetry_in_two(self) -> tuple[dict, Callable[[], None]]:
        message = self.telemetry()
        return message, lambda: self.jobs[-1].append("telemetry, finished")

    def warm(self) -> bool:
        return False

    def drawing_state(self) -> dict:
        self.jobs[-1].append("state")
        return {}

    def handle(self, verb: str, payload: object) -> dict:
        return {"ok": True}

    def pop_events(self) -> list[dict]:
        return []


class _NoTransport:
    def receive(self) -> None:
        return None

    def rejections(self) -> tuple[int, str, str]:
        return (0, "", "")

    def reply(self, request: object, body: dict) -> None: ...
    def publish_telemetry(self, message: dict) -> None: ...
    def publish_state(self, message: dict) -> None: ...
    def publish_event(self, message: dict) -> None: ...


@pytest.mark.parametrize(("rate", "telemetry_every", "state_every"), [(1000, 10, 16), (100, 1, 1)])
def test_telemetry_and_state_keep_their_rates_and_rarely_share_a_tick(
    rate: float, telemetry_every: int, state_every: int
) -> None:
    """At 1 kHz, telemetry every 10th tick and the state every 16th met on every 80th tick,
    which then overran the period; now the state waits one tick, keeping its rate."""
    ticks = 1600
    stop = threading.Event()
    session = _CountingSession(ticks, stop)
    config = LoopConfig(rate_hz=rate, fast=True)
    loop = SimLoop(session, _NoTransport(), config)
    refreshes = []
    loop.stats.refresh_percentiles = lambda: refreshes.append(loop.stats.ticks)
    loop.run(stop)
    assert loop.error is None
    jobs = session.jobs[1 : ticks + 1]
    assert abs(sum("telemetry" in j for j in jobs) - ticks // telemetry_every) <= 1
    assert abs(sum("state" in j for j in jobs) - ticks // state_every) <= 1
    if telemetry_every > 1:
        assert not any(len(j) > 1 for j in jobs)
        assert len(refreshes) == pytest.approx(ticks / STATS_INTERVAL_TICKS, abs=1)


@pytest.mark.parametrize("rate", [200.0, 250.0, 500.0, 1000.0, 2000.0])
def test_telemetry_is_built_every_nth_tick_exactly_at_any_rate(rate: float) -> None:
    """A telemetry message's `loop.ticks` steps by the same count every message, from the first
    one: at 250 Hz the queued builds ran 0, 3 or 4 ticks apart at first (the server test saw
    it), and at 500 Hz 4 to 6 apart for good."""
    ticks = 600
    stop = threading.Event()
    session = _CountingSession(ticks, stop)
    messages = _Messages(session)
    session.telemetry = lambda: messages.build("telemetry")
    loop = SimLoop(session, _NoTransport(), LoopConfig(rate_hz=rate, fast=True))
    loop.run(stop)
    assert loop.error is None
    every = max(1, math.floor(rate / LoopConfig().telemetry_hz))
    built = [tick for kind, tick in messages.built if kind == "telemetry"]
    assert len(built) >= ticks // every - 1
    assert {b - a for a, b in itertools.pairwise(built)} == {every}


def test_each_message_is_published_on_a_later_tick_than_it_was_built() -> None:
    """Building a message and publishing it took one tick 0.65-0.9 ms in the server under load:
    at 1 kHz the publish waits for a tick of its own, in order, and none is lost."""
    ticks = 400
    stop = threading.Event()
    session = _CountingSession(ticks, stop)
    messages = _Messages(session)
    session.telemetry = lambda: messages.build("telemetry")
    session.drawing_state = lambda: messages.build("state")
    transport = _NoTransport()
    transport.publish_telemetry = lambda m: messages.publish("telemetry", m)
    transport.publish_state = lambda m: messages.publish("state", m)
    loop = SimLoop(session, transport, LoopConfig(rate_hz=1000, fast=True))
    loop.run(stop)
    assert loop.error is None
    built, published = messages.built, messages.published
    assert len(published) >= len(built) - 2  # the last ones may still wait when the loop stops
    for kind, n, tick in published:
        assert built[n - 1][0] == kind and built[n - 1][1] < tick  # built on an earlier tick
    for kind in ("telemetry", "state"):  # in order within a key (not across: a telemetry
        numbers = [n for k, n, _ in published if k == kind]  # message takes two ticks)
        assert numbers == sorted(numbers)
    ticks_with_work = [t for _, t in built] + [t for _, _, t in published]
    assert len(ticks_with_work) == len(set(ticks_with_work))  # one job per tick


class _Messages:
    """Which tick built each message (numbered from 1) and which tick published it."""

    def __init__(self, session: "_CountingSession") -> None:
        self.session = session
        self.built: list[tuple[str, int]] = []
        self.published: list[tuple[str, int, int]] = []

    def build(self, kind: str) -> dict:
        self.built.append((kind, len(self.session.jobs)))
        return {"t": 0.0, "n": len(self.built)}

    def publish(self, kind: str, message: dict) -> None:
        self.published.append((kind, message["n"], len(self.session.jobs)))


class _StallingClock:
    """A fake monotonic clock: 50 µs per reading; `stall()` makes the second reading after it
    jump by `seconds`, i.e. while the loop waits for its next deadline (a descheduled thread)."""

    def __init__(self) -> None:
        self.now, self._countdown, self._jump = 0.0, -1, 0.0

    def stall(self, seconds: float) -> None:
        self._countdown, self._jump = 2, seconds

    def __call__(self) -> float:
        self._countdown -= 1
        self.now += 5e-5 + (self._jump if self._countdown == 0 else 0.0)
        return self.now


def test_periods_lost_to_a_stall_are_counted_in_the_next_telemetry() -> None:
    """A loop woken 0.2 s late drops the lost periods before its tick, so the telemetry published
    right after the stall already counts them (it used to lag a tick: a test reading telemetry
    after a stall saw fewer periods than had passed)."""
    stop = threading.Event()
    clock = _StallingClock()
    session = _CountingSession(12, stop)
    published: list[dict] = []
    transport = _NoTransport()
    transport.publish_telemetry = published.append
    stall_after = session.tick

    def tick() -> None:
        stall_after()
        if len(session.jobs) == 6:
            clock.stall(0.2)

    session.tick = tick
    loop = SimLoop(session, transport, LoopConfig(rate_hz=1000, telemetry_hz=1000), clock=clock)
    loop._run(stop)
    skipped = [m["loop"]["skipped"] for m in published]
    assert skipped[4] == 0 and 195 <= skipped[5] <= 200, skipped  # 0.2 s at 1 kHz
    assert skipped[-1] == skipped[5] and loop.stats.overruns >= 1


def test_the_loop_keeps_ticking_through_a_sim_divergence() -> None:
    """A real session whose MuJoCo state is made invalid mid-run (fault injection): the loop
    publishes sim_diverged, keeps ticking and its telemetry's clock never runs backwards."""
    stop = threading.Event()
    session = Session(SessionConfig(robot="solo12"))
    tick = session.tick

    def tick_with_fault() -> None:
        if session.ticks == 50 and session.divergences == 0:
            session.plant.mj_data.qvel[-1] = math.nan
        tick()
        if session.time > 0.2:
            stop.set()

    session.tick = tick_with_fault
    telemetry: list[dict] = []
    events: list[dict] = []
    transport = _NoTransport()
    transport.publish_telemetry = telemetry.append
    transport.publish_event = events.append
    loop = SimLoop(session, transport, LoopConfig(fast=True))
    loop.run(stop)
    assert loop.error is None
    assert [e["type"] for e in events] == ["sim_diverged"] and events[0]["t"] >= 0.05
    times = [m["t"] for m in telemetry]
    assert all(b >= a for a, b in itertools.pairwise(times)) and times[-1] > 0.19
    assert telemetry[-1]["divergences"] == 1 and not telemetry[-1]["fell"]


def test_a_whole_period_spin_never_sleeps(monkeypatch: pytest.MonkeyPatch) -> None:
    """With `spin_s` equal to the period the loop never sleeps (it keeps its CPU: no halted
    vCPU to wake) but drops the GIL while far from the deadline (`time.sleep(0)`, for the
    transport's put thread); with the default it sleeps between ticks."""
    import lab.runtime.loop as loop_module

    sleeps: list[float] = []
    real_sleep = loop_module.time.sleep

    def counting_sleep(seconds: float) -> None:
        sleeps.append(seconds)
        real_sleep(seconds)

    monkeypatch.setattr(loop_module.time, "sleep", counting_sleep)
    for spin_s, sleeps_expected in ((1e-3, False), (LoopConfig.spin_s, True)):
        sleeps.clear()
        loop = _run_loop(LoopConfig(rate_hz=1000, sched="other", spin_s=spin_s), ticks=20)
        assert loop.error is None and loop.stats.ticks >= 20
        assert any(seconds > 0.0 for seconds in sleeps) == sleeps_expected
        assert (0.0 in sleeps) != sleeps_expected  # the GIL dropped in the whole-period spin
