"""The realtime sim loop: tick the session on an absolute schedule, apply commands between ticks,
publish telemetry, keep live deadline statistics.

One thread runs `SimLoop.run`. Each iteration: sleep until a margin before the next deadline
(fixed, or learned: wake_margin.py), let the session warm what its next tick runs
(`Session.warm`: the caches went cold while the thread slept) and spin to the deadline
(`next += period`, never "sleep one period"), take waiting commands from the transport (a
bounded number per tick, already decoded and validated off this thread: lab/runtime/intake.py),
apply them through `Session.execute` and reply, run the velocity deadman (deadman.py),
`Session.tick()`, and at most one job beside it where the rates allow: build telemetry (over two
ticks) or a drawing state on its schedule, publish it (with the events: loop_events.py) on a
later tick. While the machine's floor is
measured (floor.py) the iterations are empty instead.

Beside it: the settings (loop_config.py), the deadline statistics (deadline_stats.py), the
thread's Linux scheduling (scheduling.py). Over 400 lines: one loop, its per-iteration order and
the scheduling it takes and gives back at start and stop, read top to bottom in one place.
"""

import contextlib
import functools
import math
import os
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Protocol

from lab.protocol import LIMITS, Command, FloorCommand, RobotCommand, SceneCommand, VelocityCommand
from lab.runtime.deadline_stats import DeadlineStats
from lab.runtime.deadman import Deadman
from lab.runtime.floor import FloorRun
from lab.runtime.intake import Request
from lab.runtime.loop_config import SPIN_CHOICES, LoopConfig
from lab.runtime.loop_events import LoopEvents
from lab.runtime.scheduling import (
    lower_timer_slack,
    name_os_thread,
    request_fifo,
    request_nice,
    request_slice,
    resolve_sched,
    usable_cpus,
)
from lab.runtime.wake_margin import WakeMargin
from lab.world.memory import long_lived_objects_frozen

MAX_BEHIND_S = 0.05  # after a longer stall (e.g. a robot switch) re-anchor instead of catching up
COMMAND_BUDGET_S = 3e-4  # stop taking commands in one tick after this much time on them
STATS_INTERVAL_TICKS = 50  # recompute the percentiles of one loop statistic this often
# A busy spin longer than this (e.g. the whole period) drops the GIL until this long before the
# deadline (time.sleep(0): no sleep, the GIL released and taken back), so that the transport's
# put thread can publish meanwhile; without it the put thread waited for Python's 5 ms switch
# interval and then held the GIL wherever the loop was. The last stretch holds it: a put
# takes 30-140 µs.
GIL_HOLD_S = 3e-4
# The session's warm-up of its next tick (`Session.warm`): the loop wakes this much earlier
# while the session has something to warm (a cold ANYmal warm-up takes 10-30 µs here; the sleep
# alone ends 20-50 µs late, which left no time for it in the spin's 50 µs), and warms only with
# at least WARM_MIN_S left before the deadline: woken later, it would delay the tick.
WARM_LEAD_S = 4e-5
WARM_MIN_S = 2e-5
MAX_PENDING_JOBS = 2  # more jobs beside the tick waiting than this: run them in the same tick
# Build a telemetry message over two ticks only with at least this many ticks between messages
# (three jobs a message, and the drawing state's two): at 250 Hz (every 2nd tick) in one.
SPLIT_TELEMETRY_MIN_TICKS = 5
DEFAULT_CONFIG = LoopConfig()


class Session(Protocol):
    """What the loop needs from `lab.world.session.Session`."""

    def tick(self) -> None: ...
    def warm(self) -> bool: ...
    def handle(self, verb: str, payload: object) -> dict: ...
    def execute(self, verb: str, command: object) -> dict: ...
    def refuse(self, verb: str, message: str) -> dict: ...
    def switch_config(self, command: RobotCommand | SceneCommand) -> object: ...
    def setup_commands(self, command: object) -> list[Command]: ...
    def use_setup(self, commands: list[Command]) -> dict: ...
    def install(self, parts: object) -> object: ...
    def telemetry_in_two(self) -> tuple[dict, Callable[[], None]]: ...
    def drawing_state(self) -> dict: ...
    def pop_events(self) -> list[dict]: ...


class Transport(Protocol):
    """What the loop needs from `lab.runtime.transport.ServerTransport`."""

    def receive(self) -> Request | None: ...
    def rejections(self) -> tuple[int, str, str]: ...
    def reply(self, request: Request, body: dict[str, object]) -> None: ...
    def publish_telemetry(self, message: dict[str, object]) -> None: ...
    def publish_state(self, message: dict[str, object]) -> None: ...
    def publish_event(self, message: dict[str, object]) -> None: ...


class Built(Protocol):
    """A finished switch (`lab.runtime.switch.Built`)."""

    request: Request
    parts: object
    error: str | None


class Switches(Protocol):
    """What the loop needs from `lab.runtime.switch.Switcher`: robot and scene switches built
    beside it."""

    pending: Request | None

    def start(self, request: Request, config: object) -> None: ...
    def finished(self) -> Built | None: ...
    def discard(self, old: object) -> None: ...


class SimLoop:
    """Drives one session in real time (or as fast as possible) and serves the protocol."""

    def __init__(
        self,
        session: Session,
        transport: Transport,
        config: LoopConfig = DEFAULT_CONFIG,
        clock: Callable[[], float] = time.monotonic,
        switcher: Switches | None = None,
        sleep: Callable[[float], None] | None = None,
    ) -> None:
        """`switcher` builds robot and scene switches beside the loop; without one the loop
        runs them itself, stalling for as long (fast mode, tests). `clock` and `sleep` (default
        time.sleep) are the loop's time: tests give a fake one."""
        self.session = session
        self.switcher = switcher
        self.transport = transport
        self.config = config
        self.clock = clock
        self.next_deadline = clock()  # the next tick's deadline (for the command intake)
        self.sleep = time.sleep if sleep is None else sleep
        self.period = 1.0 / config.rate_hz
        self.wanted_sched = "other" if config.fast else resolve_sched(config.sched, usable_cpus())
        if config.spin not in SPIN_CHOICES:
            raise ValueError(f"unknown spin {config.spin!r} (choices: {', '.join(SPIN_CHOICES)})")
        self.stats = DeadlineStats(self.period, realtime=not config.fast)
        self.margin = WakeMargin(self.period) if config.adaptive_spin else None
        self.floor = FloorRun(self.period)
        if config.floor_s > 0.0 and not config.fast:
            self.floor.start(config.floor_s, None)
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
        self._events = LoopEvents(self.period)
        self._last_sim_time = 0.0
        self._warming = True  # the session's last warm-up had something to warm (WARM_LEAD_S)

    def run(self, stop: threading.Event) -> None:
        """Run until `stop` is set (or the session raises: kept in `self.error`, then stop)."""
        self.stats.gc.install()
        interval = sys.getswitchinterval()
        # A full collection scans every object Python tracks (84,000 here, most of them the
        # imports'): 30 ms of CPU holding the GIL, whichever thread starts it, and one ran inside
        # a robot switch's build. What exists now (the imports, the first session) is frozen
        # while the loop runs: later collections scan only what came after (0.1 ms;
        # docs/reliability.md, "A switch beside the loop"). Unfrozen when it stops: the first
        # session's objects sit in reference cycles (its native kernel, plant step and server
        # tick) that only a collection frees; left frozen, nanobind listed them as leaked at exit.
        frozen = contextlib.nullcontext() if self.config.fast else long_lived_objects_frozen()
        with frozen:
            try:
                if not self.config.fast:
                    if self.config.switch_interval_s is not None:
                        sys.setswitchinterval(self.config.switch_interval_s)
                    lower_timer_slack()
                    name_os_thread()
                    if self.wanted_sched == "fifo" and request_fifo():
                        self.stats.sched = "fifo"
                    else:
                        if self.config.nice is not None:
                            self.stats.nice = request_nice(self.config.nice)
                        if self.config.slice_s is not None:
                            granted = request_slice(self.config.slice_s)
                            self.stats.slice_us = (
                                None if granted is None else round(granted * 1e6, 1)
                            )
                self._run(stop)
            except BaseException as exc:
                self.error = exc
                stop.set()
            finally:
                sys.setswitchinterval(interval)
                self.stats.gc.remove()

    def _run(self, stop: threading.Event) -> None:
        period, clock, fast = self.period, self.clock, self.config.fast
        deadline = clock()
        while not stop.is_set():
            self.next_deadline = deadline
            if not fast:
                self._wait_for(deadline, warm=self.config.warm and not self.floor.running)
            start = clock()
            lateness = 0.0 if fast else max(0.0, start - deadline)
            stalled = lateness > MAX_BEHIND_S
            if stalled:  # woken far behind: drop the lost periods now (this tick's telemetry
                missed = math.floor(lateness / period)  # counts them) and serve the current one
                self.stats.skipped += missed
                deadline += missed * period
                self._events.stalled(lateness)
            floor = self.floor.running
            kind = self._floor_tick() if floor else self._iterate(start)
            end = clock()
            deadline = start if fast else deadline + period
            overrun = not fast and end > deadline
            if floor:
                if self.floor.record(start, lateness, end - start, overrun or stalled):
                    self._floor_measured()
            else:
                self.stats.record(lateness, end - start, overrun or stalled, kind)
            if overrun or stalled:
                self._events.overran(max(lateness, end - deadline))
            if overrun and end - deadline > MAX_BEHIND_S:  # this tick's own work took too long
                missed = math.ceil((end - deadline) / period)
                self.stats.skipped += missed
                deadline += missed * period

    def _wait_for(self, deadline: float, warm: bool) -> None:
        """Sleep until the margin before `deadline` (learned, with `adaptive_spin`: each sleep's
        oversleep is recorded; WARM_LEAD_S earlier with `warm` while the session warms), then
        spin to it; before the last stretch, with `warm` and WARM_MIN_S to spare, let the
        session warm its next tick."""
        clock, margin = self.clock, self.margin
        wake = deadline - (self.config.spin_s if margin is None else margin.seconds)
        if warm and self._warming:
            wake -= WARM_LEAD_S
        delay = wake - clock()
        if delay > 0.0:
            self.sleep(delay)
            if margin is not None:
                margin.record(clock() - wake)
        elif margin is not None:
            margin.no_sleep()
        if self.config.spin == "yield":
            self._warm(deadline, warm)
            while clock() < deadline:  # the last stretch: yield (and the GIL), don't sleep
                os.sched_yield()
            return
        while clock() < deadline - GIL_HOLD_S:  # a long spin: the GIL stays free
            self.sleep(0)
        self._warm(deadline, warm)
        while clock() < deadline:  # the last stretch: only the clock
            pass

    def _warm(self, deadline: float, warm: bool) -> None:
        """With `warm` and at least WARM_MIN_S before `deadline`: `Session.warm`, which touches
        what the next tick runs and changes nothing (docs/performance.md, "Where the plain tick
        goes"); whether it had anything to warm decides whether the next wake-up is early."""
        if warm and deadline - self.clock() > WARM_MIN_S:
            self._warming = self.session.warm()

    def _floor_tick(self) -> str:
        """An iteration of the floor's empty loop: nothing but the margin's refresh."""
        if self.margin is not None and self.floor.stats.ticks % STATS_INTERVAL_TICKS == 0:
            self.margin.update()
        return "plain"

    def _floor_measured(self) -> None:
        """The floor's run ended: answer the `floor` command that asked for it, if any."""
        request, self.floor.request = self.floor.request, None
        if request is not None:
            self._answer(request, {"ok": True, "floor": self.floor.result})

    def snapshot(self, now: float) -> dict[str, object]:
        """The loop's `loop` object of telemetry and `info`: the deadline statistics, the
        floor last measured, the wake-up margin in use and the loop thread's CPU time."""
        margin = self.config.spin_s if self.margin is None else self.margin.seconds
        return {
            **self.stats.snapshot(),
            "floor": self.floor.result,
            "spin_margin_us": round(margin * 1e6, 1),
            "adaptive_spin": self.margin is not None,
            "cpu_s": time.thread_time(),
            "clock_s": now,
        }

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
        in the server under load, and there were about as many overruns as such ticks. A
        telemetry build runs on the tick it is due (its `loop.ticks` then steps evenly: in the
        queue at 250 Hz two were built on one tick, then one 3 ticks late); the other jobs
        wait in order for a tick of their own (at most MAX_PENDING_JOBS; when a message is due
        every tick, all run at once). The statistics' percentiles take a tick with no job.
        Returns the tick's kind (TICK_KINDS)."""
        ticks = self.stats.ticks
        if ticks % self._telemetry_every == 0:  # built on its own tick, ahead of the queue: a
            self._jobs.appendleft(self._build_telemetry)  # queued build ran 0-4 ticks late
        if ticks >= self._state_due:
            self._jobs.append(self._build_state)
            self._state_due += self._state_every
        if not self._jobs:
            if ticks >= self._stats_due:
                self.stats.refresh_percentiles()
                if self.margin is not None:
                    self.margin.update()
                self._stats_due = ticks + STATS_INTERVAL_TICKS
                return "stats"
            return "plain"
        kind = self._jobs.popleft()(now)
        while len(self._jobs) > self._max_pending:
            self._jobs.popleft()(now)
        return kind

    def _build_telemetry(self, now: float) -> str:
        telemetry, finish = self.session.telemetry_in_two()
        telemetry["loop"] = self.snapshot(now)
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
        """Apply the commands waiting (at most `max_commands_per_tick`, for at most
        COMMAND_BUDGET_S), of the velocity commands only the newest. Most ticks have none:
        one `receive` then, no clock read and no list made."""
        left = self.config.max_commands_per_tick
        request = self.transport.receive() if left > 0 else None
        if request is None:
            return
        velocity: list[Request] = []
        while request is not None:
            if isinstance(request.command, VelocityCommand):
                velocity.append(request)
            else:
                self._apply(request, now)
            left -= 1
            if left == 0 or self.clock() - now > COMMAND_BUDGET_S:
                break
            request = self.transport.receive()
        if velocity:  # latest value: only the newest velocity command is applied
            for request in velocity[:-1]:
                self._answer(request, {"ok": True, "superseded": True})
            self._apply(velocity[-1], now)

    def _apply(self, request: Request, now: float) -> None:
        switch = isinstance(request.command, RobotCommand | SceneCommand)
        if isinstance(request.command, FloorCommand):
            self._start_floor(request, request.command.seconds)
            return
        if switch and self.switcher is not None:
            if (pending := self.switcher.pending) is not None:
                message = (
                    f"{request.verb}: a {pending.verb} switch is under way; send this one again "
                    "after its reply"
                )
                self._answer(request, self.session.refuse(request.verb, message))
                return
            try:  # a set-up the scene lacks for this robot is refused before the switch
                self.session.setup_commands(request.command)
            except KeyError as error:
                self._answer(request, self.session.refuse(request.verb, error.args[0]))
                return
            self.switcher.start(request, self.session.switch_config(request.command))
            return
        reply = self.session.execute(request.verb, request.command)
        if reply.get("ok"):
            if isinstance(request.command, VelocityCommand):
                self._deadman.refresh(request.command, now)
            elif request.verb == "info":
                reply = {**reply, "limits": LIMITS, "loop": self.snapshot(now)}
            elif request.verb in ("robot", "scene", "reset"):
                self._deadman.refresh(VelocityCommand(), now)
        self._answer(request, reply)

    def _start_floor(self, request: Request, seconds: float) -> None:
        """The `floor` command: measure the floor from the next tick for the seconds asked
        (the session stands still meanwhile and commands wait); the reply carries it."""
        if self.config.fast:
            message = "floor: the loop runs in fast mode (no deadlines to measure against)"
            self._answer(request, self.session.refuse(request.verb, message))
            return
        self.floor.start(seconds, request)

    def _finish_switch(self, switcher: Switches, now: float) -> None:
        """Swap in the parts of a switch built beside the loop, and answer its command."""
        built = switcher.finished()
        if built is None:
            return
        if built.error is not None:
            self._answer(built.request, self.session.refuse(built.request.verb, built.error))
            return
        setup = self.session.setup_commands(built.request.command)  # checked at the start
        switcher.discard(self.session.install(built.parts))
        reply = self.session.use_setup(setup)  # before the new scene's first tick
        self._deadman.refresh(VelocityCommand(), now)
        self._answer(built.request, {"ok": True, **reply})

    def _answer(self, request: Request, reply: dict[str, object]) -> None:
        if not reply.get("ok"):
            self._events.rejected(1, request.verb, str(reply.get("error", "")))
        self.transport.reply(request, reply)

    def _publish_events(self, now: float) -> None:
        for event in self.session.pop_events():
            if event.get("type") != "rejected_command":  # folded below, with transport errors
                self.transport.publish_event(event)
        refused, verb, error = self.transport.rejections()  # by the intake, off this thread
        if refused:
            self._events.rejected(refused, verb, error)
        stats = self.stats
        for event in self._events.due(now, self._last_sim_time, stats.overruns, stats.skipped):
            self.transport.publish_event(event)
