"""The realtime sim loop: tick the session on an absolute schedule, apply commands between ticks,
publish telemetry, keep live deadline statistics.

One thread runs `SimLoop.run`. Each iteration: sleep until just before the next deadline and spin
to it (`next += period`, never "sleep one period"), take waiting commands from the transport (a
bounded number per tick, already decoded and validated off this thread: lab/server/intake.py),
apply them through `Session.execute` and reply, run the velocity
deadman, `Session.tick()`, and at most one job beside it where the rates allow: build telemetry
(over two ticks) or a drawing state on its schedule, publish it (with the events) on a later
tick.
"""

import contextlib
import ctypes
import functools
import gc
import math
import os
import platform
import sys
import threading
import time
from bisect import bisect_left
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from itertools import accumulate
from typing import Protocol

from lab.protocol import LIMITS, RobotCommand, SceneCommand, VelocityCommand
from lab.server.intake import Request

ON_TIME_TOLERANCE = 0.1  # a tick is on time if it starts <= 10 % of a period after its deadline
MAX_BEHIND_S = 0.05  # after a longer stall (e.g. a robot switch) re-anchor instead of catching up
DEADMAN_TIMEOUT_S = 0.5  # a velocity command expires this long after its last refresh...
DEADMAN_RAMP_S = 0.5  # ...and then ramps linearly to zero over this long
DEADMAN_UPDATE_S = 0.01  # how often the ramp sends a new velocity to the session
EVENT_INTERVAL_S = 1.0  # overrun / rejected_command / stall events: at most one per second each
# Woken this late, the loop stood still (the process stopped by SIGSTOP or a debugger, the
# machine starved): a `stall` event says for how long. Shorter lateness is an overrun's.
STALL_S = 0.2
COMMAND_BUDGET_S = 3e-4  # stop taking commands in one tick after this much time on them
STATS_INTERVAL_TICKS = 50  # recompute the percentiles of one loop statistic this often
FIFO_PRIORITY = 50
SCHED_CHOICES = ("auto", "fifo", "other")
# `auto` takes SCHED_FIFO only with this many CPUs to run on. On a 2-core machine a 1 kHz FIFO
# loop left the UI process and a local browser so little that a click took up to 4 s to reach
# the sim (issue 16); with 4 or more, one core for the loop leaves enough for the rest. Round 8
# measured FIFO on 2 cores again (docs/performance.md, "The 1 kHz loop: scheduling"): far more
# ticks on time than SCHED_OTHER under load and no 4 s clicks, but short of 99.9 %: kept for now.
# Round 9 ("The 1 kHz loop on EEVDF"): with jobs split over ticks, FIFO 96.6-98.9 % against
# SCHED_OTHER's 95-97 % at low load; its starvation not measured again: still kept.
AUTO_FIFO_MIN_CPUS = 4
SPIN_CHOICES = ("yield", "busy")
_PR_SET_TIMERSLACK = 29
# sched_setattr(2) / sched_getattr(2): not in Python's os module.
_SYS_SCHED_SETATTR = {"x86_64": 314, "aarch64": 274}
_SYS_SCHED_GETATTR = {"x86_64": 315, "aarch64": 275}
_SCHED_OTHER = 0
_SCHED_FLAG_RESET_ON_FORK = 1
# The custom slices the kernel accepts (it clamps to these; kernel/sched/syscalls.c).
SLICE_MIN_S, SLICE_MAX_S = 1e-4, 0.1
# What the loop did beside the tick: nothing, build telemetry, build the drawing state, publish
# one of them, refresh the statistics' percentiles.
TICK_KINDS = ("plain", "telemetry", "state", "publish", "stats")
# A busy spin longer than this (e.g. the whole period) drops the GIL until this long before the
# deadline (time.sleep(0): no sleep, the GIL released and taken back), so that the transport's
# put thread can publish meanwhile; without it the put thread waited for Python's 5 ms switch
# interval and then held the GIL wherever the loop was. The last stretch holds it: a put
# takes 30-140 µs.
GIL_HOLD_S = 3e-4
MAX_PENDING_JOBS = 2  # more jobs beside the tick waiting than this: run them in the same tick
# Build a telemetry message over two ticks only with at least this many ticks between messages
# (three jobs a message, and the drawing state's two): at 250 Hz (every 2nd tick) in one.
SPLIT_TELEMETRY_MIN_TICKS = 5


class Session(Protocol):
    """What the loop needs from `lab.server.session.Session`."""

    def tick(self) -> None: ...
    def handle(self, verb: str, payload: object) -> dict: ...
    def execute(self, verb: str, command: object) -> dict: ...
    def refuse(self, verb: str, message: str) -> dict: ...
    def switch_config(self, command: RobotCommand | SceneCommand) -> object: ...
    def install(self, parts: object) -> object: ...
    def telemetry_in_two(self) -> tuple[dict, Callable[[], None]]: ...
    def drawing_state(self) -> dict: ...
    def pop_events(self) -> list[dict]: ...


class Transport(Protocol):
    """What the loop needs from `lab.server.transport.ServerTransport`."""

    def receive(self) -> Request | None: ...
    def rejections(self) -> tuple[int, str, str]: ...
    def reply(self, request: Request, body: dict[str, object]) -> None: ...
    def publish_telemetry(self, message: dict[str, object]) -> None: ...
    def publish_state(self, message: dict[str, object]) -> None: ...
    def publish_event(self, message: dict[str, object]) -> None: ...


class Built(Protocol):
    """A finished switch (`lab.server.switch.Built`)."""

    request: Request
    parts: object
    error: str | None


class Switches(Protocol):
    """What the loop needs from `lab.server.switch.Switcher`: robot and scene switches built
    beside it."""

    pending: Request | None

    def start(self, request: Request, config: object) -> None: ...
    def finished(self) -> Built | None: ...
    def discard(self, old: object) -> None: ...


@dataclass(frozen=True)
class LoopConfig:
    rate_hz: float = 1000.0
    fast: bool = False  # no sleeping: run as fast as the CPU allows
    # Scheduling policy of the loop thread: "fifo" asks for SCHED_FIFO (refusal is ignored),
    # "other" keeps SCHED_OTHER, "auto" is "fifo" with AUTO_FIFO_MIN_CPUS CPUs or more, else
    # "other". Fast mode never asks for FIFO: it would starve the machine.
    sched: str = "auto"
    telemetry_hz: float = 100.0
    state_hz: float = 60.0
    max_commands_per_tick: int = 4
    # Sleep until this long before a deadline, then spin. On this project's 2-core VM a sleep
    # woke more than 10 % of a period late on ~1.5 % of ticks (the idle vCPU halts; waking it
    # takes the host 35-50 µs at the median): a short spin keeps the tail in. Spinning the whole
    # period instead gets the loop throttled by the kernel's realtime budget (50 ms stalls at
    # SCHED_FIFO), and at SCHED_OTHER every µs of spin is CPU time EEVDF charges the loop with.
    # 0.05 ms, busy, with the slice below: the best of the settings measured in round 9
    # (docs/performance.md, "The 1 kHz loop on EEVDF").
    spin_s: float = 5e-5
    # How to spend the spin: "busy" only reads the clock; "yield" calls sched_yield, which under
    # EEVDF pushes the loop's virtual deadline back a slice, so a runnable neighbour goes first:
    # it doubled the late wake-ups (round 9). The transport's put thread takes the GIL for each
    # put, normally while the loop sleeps; in a spin longer than GIL_HOLD_S the loop drops the
    # GIL until GIL_HOLD_S before the deadline (Zenoh's own threads run no Python; the main
    # thread waits on an Event).
    spin: str = "busy"
    # The EEVDF slice (s) to ask for at SCHED_OTHER (Linux >= 6.12, unprivileged; threads the
    # loop starts keep the default): a waking thread with a shorter slice than the running one
    # preempts it (PREEMPT_SHORT) instead of waiting for that slice to end, which this kernel
    # (HZ=250) notices only at its next 4 ms tick. None keeps the kernel's default (1.4 ms here).
    slice_s: float | None = 1e-4
    # The nice value to ask for at SCHED_OTHER (a negative one needs CAP_SYS_NICE or a raised
    # RLIMIT_NICE; refusal is expected and ignored). EEVDF weighs a thread ~1.25x per step: at
    # -10 the loop weighs 9.3 default threads, so the CPU time it spends does not push its
    # virtual deadline behind its neighbours' and its wake-ups still preempt them. Unlike
    # SCHED_FIFO it cannot starve them: they keep their fair share. None leaves it as it is.
    nice: int | None = -10
    # The interpreter's switch interval (sys.setswitchinterval) while the loop runs in real
    # time: how long the loop, woken for a tick, waits at most for the GIL when another thread
    # of the process (the command intake under a flood, a switch being built) holds it. Python's
    # default, 5 ms, is five periods (issue 25, docs/reliability.md). None leaves it.
    switch_interval_s: float | None = 2e-4


def _geometric_edges(low: float, ratio: float, count: int) -> list[float]:
    """low, low·ratio, …, low·ratio^(count-1)."""
    return [low * ratio**i for i in range(count)]


class LogHistogram:
    """Counts of positive durations in geometric bins (5 % wide from 0.1 µs to 10 s); cheap to
    record every tick, percentiles read as the upper edge of the bin.

    Both are C calls on a list, not Python arithmetic: a record is one `bisect` over the bin
    edges (the log, division and `min` it replaced cost ~1 µs a record, three records a tick), a
    percentile one `accumulate` and one `bisect` (a Python pass over the bins cost ~0.1 ms a
    percentile in the server, six at every refresh: docs/performance.md, round 10)."""

    LOW_S = 1e-7
    RATIO = 1.05
    BINS = 380
    # Upper edge of bin i < BINS; bin 0 holds durations <= LOW_S, bin BINS those above the last
    # edge (only their maximum is known).
    EDGES = _geometric_edges(LOW_S, RATIO, BINS)

    def __init__(self) -> None:
        self.counts = [0] * (self.BINS + 1)
        self.total = 0
        self.max = 0.0

    def record(self, seconds: float) -> None:
        self.counts[bisect_left(self.EDGES, seconds)] += 1
        self.total += 1
        if seconds > self.max:
            self.max = seconds

    def percentile(self, p: float) -> float:
        """Upper edge of the bin holding the p-th percentile (s), capped at the maximum."""
        return self.percentiles(p)[0]

    def percentiles(self, *ps: float) -> list[float]:
        """`percentile` of each of `ps`, with one pass over the bins for all."""
        if self.total == 0:
            return [0.0] * len(ps)
        cumulative = list(accumulate(self.counts))
        edges = self.EDGES
        out = []
        for p in ps:
            index = bisect_left(cumulative, p / 100.0 * self.total)
            out.append(min(self.max, edges[index]) if index < self.BINS else self.max)
        return out


class DeadlineStats:
    """Live statistics of the schedule: lateness of each tick start, work per iteration,
    on-time ticks, overruns (work ended after the next deadline), skipped periods, and which
    late ticks were woken late (the tick before ended in time) rather than pushed by an overrun."""

    def __init__(self, period: float, realtime: bool, sched: str = "other") -> None:
        self.period = period
        self.realtime = realtime
        self.sched = sched  # the policy in effect: "fifo" or "other"
        self.slice_us: float | None = None  # the custom EEVDF slice in effect, if any
        self.nice: int | None = None  # the nice value the loop was granted, if it asked
        self.ticks = 0
        self.on_time = 0
        self.overruns = 0
        self.skipped = 0
        self.late_wakeups = 0
        self._previous_overran = False
        self.lateness = LogHistogram()
        self.work = LogHistogram()
        self.work_by_kind = {kind: LogHistogram() for kind in TICK_KINDS}
        # Lateness of the late ticks, by cause: woken late, or pushed by the overrun before.
        self.late_woken = LogHistogram()
        self.late_pushed = LogHistogram()
        self.gc = GcPauses()
        self._percentiles: dict[str, dict[str, float]] = {"lateness_us": {}, "tick_us": {}}
        self._details: dict[str, dict[str, dict[str, float]]] = {
            "tick_us_by_kind": {},
            "late_lateness_us": {},
            "gc_pause_us": {},
        }
        details = [
            *((self._details["tick_us_by_kind"], kind, h) for kind, h in self.work_by_kind.items()),
            (self._details["late_lateness_us"], "woken", self.late_woken),
            (self._details["late_lateness_us"], "pushed", self.late_pushed),
            (self._details["gc_pause_us"], "all", self.gc.pauses),
        ]
        # One histogram per refresh, round and round: lateness, work, then the next detail.
        self._refresh_order: list[tuple[dict[str, dict[str, float]], str, LogHistogram]] = []
        for detail in details:
            self._refresh_order += [
                (self._percentiles, "lateness_us", self.lateness),
                (self._percentiles, "tick_us", self.work),
                detail,
            ]
        self._next_refresh = 0
        for target, key, histogram in self._refresh_order:
            target[key] = _us(histogram)

    def record(self, lateness: float, work: float, overrun: bool, kind: str = "plain") -> None:
        self.ticks += 1
        on_time = lateness <= ON_TIME_TOLERANCE * self.period
        self.on_time += on_time
        if not on_time:
            if self._previous_overran:
                self.late_pushed.record(lateness)
            else:
                self.late_wakeups += 1
                self.late_woken.record(lateness)
        self._previous_overran = overrun
        self.overruns += overrun
        self.lateness.record(lateness)
        self.work.record(work)
        self.work_by_kind[kind].record(work)

    def refresh_percentiles(self) -> None:
        """Recompute the percentiles of one histogram (a pass over its bins: not every tick):
        lateness or work on two refreshes of three, one of the details (by tick kind, late
        ticks, GC) in turn on the third."""
        target, key, histogram = self._refresh_order[self._next_refresh]
        self._next_refresh = (self._next_refresh + 1) % len(self._refresh_order)
        target[key] = _us(histogram)

    def snapshot(self) -> dict[str, object]:
        """Counters as of now, percentiles as of the last `refresh_percentiles`."""
        return {
            "rate_hz": 1.0 / self.period,
            "realtime": self.realtime,
            "fifo": self.sched == "fifo",
            "sched": self.sched,
            "ticks": self.ticks,
            "on_time_fraction": self.on_time / self.ticks if self.ticks else 1.0,
            **self._percentiles,
            "overruns": self.overruns,
            "late_wakeups": self.late_wakeups,
            "skipped": self.skipped,
            "slice_us": self.slice_us,
            "nice": self.nice,
            "gc_collections": list(self.gc.counts),
            **self._details,
        }


def _us(h: LogHistogram) -> dict[str, float]:
    """p50, p99 and maximum of `h` in µs."""
    p50, p99 = h.percentiles(50, 99)
    return {"p50": round(p50 * 1e6, 2), "p99": round(p99 * 1e6, 2), "max": round(h.max * 1e6, 2)}


class GcPauses:
    """How often Python's garbage collector ran in this process (by generation) and for how
    long, through `gc.callbacks` while installed. A collection stops every thread of the
    process, the loop's included, whichever thread triggered it."""

    def __init__(self) -> None:
        self.counts = [0, 0, 0]
        self.pauses = LogHistogram()
        self._start = 0.0

    def __call__(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._start = time.perf_counter()
        else:
            self.counts[info["generation"]] += 1
            self.pauses.record(time.perf_counter() - self._start)

    def install(self) -> None:
        gc.callbacks.append(self)

    def remove(self) -> None:
        with contextlib.suppress(ValueError):
            gc.callbacks.remove(self)


class Deadman:
    """A velocity command expires `DEADMAN_TIMEOUT_S` after its last refresh, then ramps
    linearly to zero over `DEADMAN_RAMP_S`."""

    def __init__(self) -> None:
        self._command = VelocityCommand()
        self._refreshed = 0.0
        self._last_update = 0.0
        self._active = False

    def refresh(self, command: VelocityCommand, now: float) -> None:
        self._command = command
        self._refreshed = now
        self._active = command != VelocityCommand()

    def update(self, now: float) -> VelocityCommand | None:
        """The decayed command to send now, or None when nothing needs to change."""
        age = now - self._refreshed
        if not self._active or age <= DEADMAN_TIMEOUT_S:
            return None
        scale = max(0.0, 1.0 - (age - DEADMAN_TIMEOUT_S) / DEADMAN_RAMP_S)
        if scale > 0.0 and now - self._last_update < DEADMAN_UPDATE_S:
            return None
        self._last_update = now
        self._active = scale > 0.0
        c = self._command
        return VelocityCommand(c.vx * scale, c.vy * scale, c.yaw_rate * scale)


class EventThrottle:
    """Folds bursts of one kind of event into at most one message per `EVENT_INTERVAL_S`."""

    def __init__(self) -> None:
        self.pending = 0
        self._last = -math.inf

    def hit(self) -> None:
        self.pending += 1

    def take(self, now: float) -> int:
        """How many hits to report now (0 when nothing is due)."""
        if self.pending == 0 or now - self._last < EVENT_INTERVAL_S:
            return 0
        count, self.pending, self._last = self.pending, 0, now
        return count


def lower_timer_slack() -> None:
    """Ask for 1 ns timer slack for the calling thread (default 50 µs); ignore refusal."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_TIMERSLACK, ctypes.c_ulong(1), 0, 0, 0)


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def resolve_sched(requested: str, cpus: int) -> str:
    """The policy to ask for, "fifo" or "other", for LoopConfig.sched `requested`."""
    if requested not in SCHED_CHOICES:
        raise ValueError(f"unknown scheduling {requested!r} (choices: {', '.join(SCHED_CHOICES)})")
    if requested == "auto":
        return "fifo" if cpus >= AUTO_FIFO_MIN_CPUS else "other"
    return requested


def request_fifo() -> bool:
    """Ask for SCHED_FIFO for the calling thread; True if granted. Refusal (no privileges) is
    expected and ignored. Threads it starts later (Zenoh spawns some lazily) do not inherit the
    realtime priority (SCHED_RESET_ON_FORK): only the loop itself may starve the machine."""
    policy = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
    try:
        os.sched_setscheduler(0, policy, os.sched_param(FIFO_PRIORITY))
    except (OSError, AttributeError):
        return False
    return True


class _SchedAttr(ctypes.Structure):
    """struct sched_attr, its first version (SCHED_ATTR_SIZE_VER0: 48 bytes)."""

    _fields_ = [
        ("size", ctypes.c_uint32),
        ("sched_policy", ctypes.c_uint32),
        ("sched_flags", ctypes.c_uint64),
        ("sched_nice", ctypes.c_int32),
        ("sched_priority", ctypes.c_uint32),
        ("sched_runtime", ctypes.c_uint64),
        ("sched_deadline", ctypes.c_uint64),
        ("sched_period", ctypes.c_uint64),
    ]


def _sched_attr_call(table: dict[str, int], attr: _SchedAttr, *extra: int) -> bool:
    """sched_getattr/sched_setattr on the calling thread; False when refused or unavailable."""
    number = table.get(platform.machine())
    if number is None:
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.syscall(number, 0, ctypes.byref(attr), *extra, 0) == 0
    except (OSError, AttributeError):
        return False


def _fair_attr() -> _SchedAttr | None:
    """The calling thread's sched_getattr, or None when unavailable or it is not SCHED_OTHER."""
    attr = _SchedAttr(size=ctypes.sizeof(_SchedAttr))
    if not _sched_attr_call(_SYS_SCHED_GETATTR, attr, ctypes.sizeof(_SchedAttr)):
        return None
    return attr if attr.sched_policy == _SCHED_OTHER else None


def _change_fair_attr(runtime_ns: int, nice: int | None) -> bool:
    """sched_setattr on the calling SCHED_OTHER thread: `runtime_ns` (its EEVDF slice; 0 is the
    kernel's default) and, unless None, `nice` (else the one it has), with
    SCHED_FLAG_RESET_ON_FORK, so that threads it starts later get neither. False when refused,
    unavailable, or the thread is not SCHED_OTHER; the thread is then left as it was."""
    attr = _fair_attr()
    if attr is None:
        return False
    attr.size = ctypes.sizeof(_SchedAttr)
    attr.sched_flags |= _SCHED_FLAG_RESET_ON_FORK
    attr.sched_runtime = runtime_ns
    if nice is not None:
        attr.sched_nice = nice
    return _sched_attr_call(_SYS_SCHED_SETATTR, attr)


def request_slice(seconds: float) -> float | None:
    """Ask for an EEVDF slice of `seconds` for the calling SCHED_OTHER thread (sched_setattr's
    sched_runtime; Linux >= 6.12, no privileges needed, clamped to SLICE_MIN_S..SLICE_MAX_S).
    A waking thread whose slice is shorter than the running thread's preempts it at once
    instead of waiting for that slice to end. Returns the slice in effect (s) as the kernel
    reads it back, or None when refused, unsupported (an older kernel ignores the field and
    reads back 0) or the thread is not SCHED_OTHER; the thread is then left as it was. Threads
    it starts later get the default slice (SCHED_FLAG_RESET_ON_FORK)."""
    if not _change_fair_attr(max(1, round(seconds * 1e9)), nice=None):
        return None
    return thread_slice()


def request_nice(nice: int) -> int | None:
    """Ask for nice value `nice` for the calling SCHED_OTHER thread (sched_setattr's sched_nice;
    it also resets the thread's EEVDF slice to the kernel's default: ask for a slice after it,
    `request_slice` keeps the nice). Raising the priority (a negative nice) needs CAP_SYS_NICE or
    a raised RLIMIT_NICE: refusal is expected, and leaves the thread as it was. Threads it starts
    later get nice 0 (SCHED_FLAG_RESET_ON_FORK). Returns the nice in effect, or None when
    refused, unavailable, or the thread is not SCHED_OTHER."""
    if not _change_fair_attr(0, nice):
        return None
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def thread_slice() -> float | None:
    """The calling SCHED_OTHER thread's EEVDF slice (s): its custom one, else the kernel's
    default; None for other policies, and on kernels without custom slices (they read back 0)."""
    attr = _fair_attr()
    if attr is None or attr.sched_runtime == 0:
        return None
    return attr.sched_runtime * 1e-9


class SimLoop:
    """Drives one session in real time (or as fast as possible) and serves the protocol."""

    def __init__(
        self,
        session: Session,
        transport: Transport,
        config: LoopConfig = LoopConfig(),
        clock: Callable[[], float] = time.monotonic,
        switcher: Switches | None = None,
    ) -> None:
        """`switcher` builds robot and scene switches beside the loop; without one the loop
        runs them itself, stalling for as long (fast mode, tests)."""
        self.session = session
        self.switcher = switcher
        self.transport = transport
        self.config = config
        self.clock = clock
        self.period = 1.0 / config.rate_hz
        self.wanted_sched = "other" if config.fast else resolve_sched(config.sched, usable_cpus())
        if config.spin not in SPIN_CHOICES:
            raise ValueError(f"unknown spin {config.spin!r} (choices: {', '.join(SPIN_CHOICES)})")
        self.stats = DeadlineStats(self.period, realtime=not config.fast)
        self.error: BaseException | None = None
        self._telemetry_every = max(1, math.floor(config.rate_hz / config.telemetry_hz))
        self._state_every = max(1, math.floor(config.rate_hz / config.state_hz))
        self._state_due = self._state_every // 2  # tick of the next drawing state
        self._stats_due = 1  # tick of the next percentile refresh
        self._jobs: deque[Callable[[float], str]] = deque()  # beside the tick, in order
        every_tick = min(self._telemetry_every, self._state_every) == 1
        self._max_pending = 0 if every_tick else MAX_PENDING_JOBS
        self._split_telemetry = self._telemetry_every >= SPLIT_TELEMETRY_MIN_TICKS
        self._deadman = Deadman()
        self._overrun_events = EventThrottle()
        self._rejected_events = EventThrottle()
        self._last_rejection: tuple[str, str] = ("", "")
        self._worst_lateness = 0.0
        self._last_sim_time = 0.0
        self._stall_events = EventThrottle()
        self._longest_stall = 0.0  # s, since the last stall event

    def run(self, stop: threading.Event) -> None:
        """Run until `stop` is set (or the session raises: kept in `self.error`, then stop)."""
        self.stats.gc.install()
        interval = sys.getswitchinterval()
        try:
            if not self.config.fast:
                if self.config.switch_interval_s is not None:
                    sys.setswitchinterval(self.config.switch_interval_s)
                lower_timer_slack()
                if self.wanted_sched == "fifo" and request_fifo():
                    self.stats.sched = "fifo"
                else:
                    if self.config.nice is not None:
                        self.stats.nice = request_nice(self.config.nice)
                    if self.config.slice_s is not None:
                        granted = request_slice(self.config.slice_s)
                        self.stats.slice_us = None if granted is None else round(granted * 1e6, 1)
            self._run(stop)
        except BaseException as exc:
            self.error = exc
            stop.set()
        finally:
            sys.setswitchinterval(interval)
            self.stats.gc.remove()

    def _run(self, stop: threading.Event) -> None:
        period, clock, fast = self.period, self.clock, self.config.fast
        spin_yield = self.config.spin == "yield"
        deadline = clock()
        while not stop.is_set():
            if not fast:
                delay = deadline - clock() - self.config.spin_s
                if delay > 0.0:
                    time.sleep(delay)
                if spin_yield:
                    while clock() < deadline:  # the last stretch: yield (and the GIL), don't sleep
                        os.sched_yield()
                else:
                    while clock() < deadline - GIL_HOLD_S:  # a long spin: the GIL stays free
                        time.sleep(0)
                    while clock() < deadline:  # the last stretch: only the clock
                        pass
            start = clock()
            lateness = 0.0 if fast else max(0.0, start - deadline)
            stalled = lateness > MAX_BEHIND_S
            if stalled:  # woken far behind: drop the lost periods now (this tick's telemetry
                missed = math.floor(lateness / period)  # counts them) and serve the current one
                self.stats.skipped += missed
                deadline += missed * period
                if lateness > STALL_S:
                    self._stall_events.hit()
                    self._longest_stall = max(self._longest_stall, lateness)
            kind = self._iterate(start)
            end = clock()
            deadline = start if fast else deadline + period
            overrun = not fast and end > deadline
            self.stats.record(lateness, end - start, overrun or stalled, kind)
            if overrun or stalled:
                self._overrun_events.hit()
                self._worst_lateness = max(self._worst_lateness, lateness, end - deadline)
            if overrun and end - deadline > MAX_BEHIND_S:  # this tick's own work took too long
                missed = math.ceil((end - deadline) / period)
                self.stats.skipped += missed
                deadline += missed * period

    def _iterate(self, now: float) -> str:
        """One tick and the work beside it; which kind of tick it was (TICK_KINDS)."""
        if self.switcher is not None and self.switcher.pending is not None:
            self._finish_switch(self.switcher, now)
        self._apply_commands(now)
        decayed = self._deadman.update(now)
        if decayed is not None:
            self.session.handle("velocity", decayed.payload())
        self.session.tick()
        return self._after_tick(now)

    def _after_tick(self, now: float) -> str:
        """The work beside the tick, one job per tick where the rates allow: build a telemetry
        message (in two steps, on two ticks: `Session.telemetry_in_two`) or a drawing state on
        its schedule, and publish it (encoding; the Zenoh put is the transport's thread's) on a
        later tick. Building and publishing on one tick made it 0.65-1.06 ms long at the median
        in the server under load, and there were about as many overruns as such ticks. Jobs
        wait in order for a tick of their own (at most MAX_PENDING_JOBS; when a message is due
        every tick, all run at once). The statistics' percentiles take a tick with no job.
        Returns the tick's kind (TICK_KINDS)."""
        ticks = self.stats.ticks
        if ticks % self._telemetry_every == 0:
            self._jobs.append(self._build_telemetry)
        if ticks >= self._state_due:
            self._jobs.append(self._build_state)
            self._state_due += self._state_every
        if not self._jobs:
            if ticks >= self._stats_due:
                self.stats.refresh_percentiles()
                self._stats_due = ticks + STATS_INTERVAL_TICKS
                return "stats"
            return "plain"
        kind = self._jobs.popleft()(now)
        while len(self._jobs) > self._max_pending:
            self._jobs.popleft()(now)
        return kind

    def _build_telemetry(self, now: float) -> str:
        telemetry, finish = self.session.telemetry_in_two()
        telemetry["loop"] = {**self.stats.snapshot(), "clock_s": now}
        self._last_sim_time = float(telemetry["t"])
        if self._split_telemetry:
            self._jobs.append(functools.partial(self._finish_telemetry, telemetry, finish))
        else:
            self._finish_telemetry(telemetry, finish, now)
        return "telemetry"

    def _finish_telemetry(self, telemetry: dict, finish: Callable[[], None], now: float) -> str:
        finish()
        self._jobs.append(functools.partial(self._publish_telemetry, telemetry))
        return "telemetry"

    def _publish_telemetry(self, telemetry: dict, now: float) -> str:
        self.transport.publish_telemetry(telemetry)
        self._publish_events(now)
        return "publish"

    def _build_state(self, now: float) -> str:
        self._jobs.append(functools.partial(self._publish_state, self.session.drawing_state()))
        return "state"

    def _publish_state(self, state: dict, now: float) -> str:
        self.transport.publish_state(state)
        return "publish"

    def _apply_commands(self, now: float) -> None:
        velocity: list[Request] = []
        for _ in range(self.config.max_commands_per_tick):
            if self.clock() - now > COMMAND_BUDGET_S:
                break
            request = self.transport.receive()
            if request is None:
                break
            if isinstance(request.command, VelocityCommand):
                velocity.append(request)
            else:
                self._apply(request, now)
        if velocity:  # latest value: only the newest velocity command is applied
            for request in velocity[:-1]:
                self._answer(request, {"ok": True, "superseded": True})
            self._apply(velocity[-1], now)

    def _apply(self, request: Request, now: float) -> None:
        switch = isinstance(request.command, RobotCommand | SceneCommand)
        if switch and self.switcher is not None:
            if (pending := self.switcher.pending) is not None:
                message = (
                    f"{request.verb}: a {pending.verb} switch is under way; send this one again "
                    "after its reply"
                )
                self._answer(request, self.session.refuse(request.verb, message))
            else:
                self.switcher.start(request, self.session.switch_config(request.command))
            return
        reply = self.session.execute(request.verb, request.command)
        if reply.get("ok"):
            if isinstance(request.command, VelocityCommand):
                self._deadman.refresh(request.command, now)
            elif request.verb == "info":
                reply = {**reply, "limits": LIMITS, "loop": self.stats.snapshot()}
            elif request.verb in ("robot", "scene", "reset"):
                self._deadman.refresh(VelocityCommand(), now)
        self._answer(request, reply)

    def _finish_switch(self, switcher: Switches, now: float) -> None:
        """Swap in the parts of a switch built beside the loop, and answer its command."""
        built = switcher.finished()
        if built is None:
            return
        if built.error is not None:
            self._answer(built.request, self.session.refuse(built.request.verb, built.error))
            return
        switcher.discard(self.session.install(built.parts))
        self._deadman.refresh(VelocityCommand(), now)
        self._answer(built.request, {"ok": True})

    def _answer(self, request: Request, reply: dict[str, object]) -> None:
        if not reply.get("ok"):
            self._rejected_events.hit()
            self._last_rejection = (request.verb[:64], str(reply.get("error", ""))[:300])
        self.transport.reply(request, reply)

    def _publish_events(self, now: float) -> None:
        for event in self.session.pop_events():
            if event.get("type") != "rejected_command":  # folded below, with transport errors
                self.transport.publish_event(event)
        overruns = self._overrun_events.take(now)
        if overruns:
            worst = self._worst_lateness * 1e6
            self._worst_lateness = 0.0
            self.transport.publish_event(
                {
                    "type": "overrun",
                    "t": self._last_sim_time,
                    "message": f"{overruns} tick(s) overran the {self.period * 1e3:g} ms period",
                    "count": overruns,
                    "total": self.stats.overruns,
                    "max_lateness_us": round(worst, 1),
                }
            )
        stalls = self._stall_events.take(now)
        if stalls:
            longest, self._longest_stall = self._longest_stall, 0.0
            self.transport.publish_event(
                {
                    "type": "stall",
                    "t": self._last_sim_time,
                    "message": f"the loop stood still for {longest:.2f} s (the process was "
                    "stopped or starved); the periods lost were skipped, not caught up",
                    "count": stalls,
                    "seconds": round(longest, 3),
                    "skipped": self.stats.skipped,
                }
            )
        refused, verb, error = self.transport.rejections()  # by the intake, off this thread
        if refused:
            self._rejected_events.pending += refused
            self._last_rejection = (verb, error)
        rejected = self._rejected_events.take(now)
        if rejected:
            verb, error = self._last_rejection
            self.transport.publish_event(
                {
                    "type": "rejected_command",
                    "t": self._last_sim_time,
                    "message": f"{rejected} command(s) rejected; last: {error}",
                    "verb": verb,
                    "error": error,
                    "count": rejected,
                }
            )
