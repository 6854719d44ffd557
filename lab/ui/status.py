"""The status line: what runs (the robot of the telemetry, not a remembered one; the kernel,
method, solver and formulation that computed the tick, telemetry's `ran`), how fast, the tick's
status (ok, fallback, capped, violated, failed) and every warning in effect: a fall, fallback
torques, a status other than ok with its level and reason, ticks slower than the loop period, a
sim slower than real time, a loop that keeps few ticks on time or overruns (pure: tested in
tests/ui/test_ui_logic.py).

Live figures are shown over the last few seconds beside the session's: a loop that collapsed
under `nullspace` showed 73.9 % on time averaged over the session while 1.9 % of its recent
ticks were. A figure beyond its target is marked (bold, with the target), never "ok".
"""

import math
import statistics
from collections import deque
from dataclasses import dataclass

SLOW_RTF = 0.9  # a realtime loop whose sim runs slower than this fraction of real time is warned
WINDOW_S = 5.0  # s of wall time over which the live figures (on-time, overruns) are taken
# The loop's on-time target: the low end of what an empty 1 kHz loop gets on this kind of
# virtual machine (docs/architecture.md: 98-99.6 %); below it the figure is marked.
ON_TIME_TARGET = 0.98
# With the machine's floor measured by the sim process (telemetry's `loop.floor`, issue 31) the
# target is the floor less this much: a figure further below it is the lab's, not the host's.
BELOW_FLOOR_ALLOWED = 0.003
COLLAPSED_ON_TIME = 0.5  # fewer recent ticks on time than this: a warning, not only a mark
# The controller's share of the loop period: beyond it the rest of the tick (MuJoCo's step,
# sensing, telemetry) no longer fits and ticks overrun ("control 972 µs (ok)" at 11 % on time).
CONTROL_SHARE = 0.6
CONTROL_WINDOW = 50  # telemetry messages (0.5 s at 100 Hz) over which a slow tick is judged


def control_budget_us(tel: dict) -> float:
    """The loop period in µs (the controller's budget per tick); 1 ms when unknown."""
    rate = tel.get("loop", {}).get("rate_hz")
    return 1e6 / rate if rate else 1000.0


@dataclass(frozen=True)
class LoopWindow:
    """The loop's deadline figures over the last `seconds` of wall time (from the session's
    counters in telemetry's `loop`): ticks, the fraction on time, overruns."""

    seconds: float
    ticks: int
    on_time_fraction: float
    overruns: int


class LoopFigures:
    """Windowed figures from the loop's session counters (`ticks`, `on_time_fraction`,
    `overruns` of telemetry's `loop`): the difference between now and WINDOW_S ago. Counters
    that go back (a new sim process) start the window again."""

    def __init__(self, window_s: float = WINDOW_S) -> None:
        self.window_s = window_s
        self._samples: deque[tuple[float, int, float, int]] = deque()  # wall, ticks, on time, over

    def add(self, wall: float, loop: dict) -> None:
        """One telemetry message's `loop`, received at `wall` (monotonic s)."""
        ticks = int(loop.get("ticks", 0))
        on_time = loop.get("on_time_fraction", 1.0) * ticks
        overruns = int(loop.get("overruns", 0))
        if self._samples and ticks < self._samples[-1][1]:
            self._samples.clear()
        self._samples.append((wall, ticks, on_time, overruns))
        while len(self._samples) > 2 and self._samples[1][0] <= wall - self.window_s:
            self._samples.popleft()

    def window(self) -> LoopWindow | None:
        """None until two messages with ticks between them have arrived."""
        if len(self._samples) < 2:
            return None
        (w0, t0, on0, over0), (w1, t1, on1, over1) = self._samples[0], self._samples[-1]
        if t1 <= t0:
            return None
        return LoopWindow(w1 - w0, t1 - t0, (on1 - on0) / (t1 - t0), over1 - over0)


def status_of(tel: dict) -> dict:
    """Telemetry's `status` (status, level, reason); a recording made before it existed (served
    by `lab replay --serve`) has `qp.status` (ok or failed) instead."""
    return tel.get("status") or {"status": tel["qp"]["status"], "level": None, "reason": ""}


def warnings_of(
    tel: dict,
    control_us: float | None = None,
    rtf: float = math.nan,
    loop: LoopWindow | None = None,
) -> dict:
    """Warnings in effect, by kind: `control_us` is the recent typical controller time per tick
    (default: the last tick's), `rtf` the measured real-time factor, `loop` the loop's recent
    deadline figures."""
    qp, status = tel["qp"], status_of(tel)
    control_us = qp["solve_us"] if control_us is None else control_us
    budget = control_budget_us(tel)
    found = {}
    if tel["fell"]:
        found["fell"] = "the robot fell: torques off until Reset"
    if status["status"] == "failed":
        found["fallback"] = f"controller failed: fallback torques ({qp['failures']} ticks)"
    elif status["status"] != "ok":
        level = "" if status["level"] is None else f" at level {status['level']}"
        found["status"] = f"controller {status['status']}{level}: {status['reason']}"
    if control_us > budget:
        found["slow"] = (
            f"slow ticks: the controller takes {control_us / 1000:.1f} ms per tick, over the "
            f"{budget / 1000:.1f} ms period"
        )
    note = tel.get("ran", {}).get("note") or tel.get("kernel_note")
    if note:
        found["kernel"] = f"{tel['kernel']} kernel ran: {note}"
    for warning in tel.get("controller_warnings", ()):
        found[f"controller {warning['kind']}"] = f"controller warning: {warning['message']}"
    realtime = tel.get("loop", {}).get("realtime", False)
    if realtime and not tel["paused"] and math.isfinite(rtf) and rtf < SLOW_RTF:
        found["behind"] = f"the sim runs at {rtf:.2f}× real time"
    if realtime and loop is not None and loop.overruns:
        found["overrun"] = (
            f"{loop.overruns} tick(s) overran the {budget / 1000:g} ms period in the last "
            f"{loop.seconds:.0f} s"
        )
    if realtime and loop is not None and loop.on_time_fraction < COLLAPSED_ON_TIME:
        found["collapsed"] = (
            f"the loop kept {100 * loop.on_time_fraction:.1f} % of its ticks on time in the "
            f"last {loop.seconds:.0f} s"
        )
    return found


def started_warnings(now: dict[str, str], before: set[str]) -> list[tuple[str, str]]:
    """The (kind, text) of the warnings in effect `now` that were not in effect `before`: what
    the event log gets, once per start."""
    return [(kind, text) for kind, text in now.items() if kind not in before]


def qp_state(tel: dict, warnings: dict) -> str:
    """`ok` only when nothing is wrong with the controller's ticks."""
    status = status_of(tel)["status"]
    if status != "ok":
        return f"**{status}**"
    if "slow" in warnings:
        return "**slow**"
    if any(kind.startswith("controller ") for kind in warnings):
        return "**warning**"
    return status


def control_text(tel: dict, control_us: float, warnings: dict) -> str:
    """The controller's time per tick with its state; beyond CONTROL_SHARE of the period it is
    marked (the rest of the tick no longer fits), never "ok"."""
    state = qp_state(tel, warnings)
    share = CONTROL_SHARE * control_budget_us(tel)
    if state == "ok" and control_us > share:
        state = f"**over {share:.0f} µs**"
    return f"control {control_us:.0f} µs ({state})"


def on_time_text(loop: dict, window: LoopWindow | None) -> str:
    """The loop's on-time fraction over the last seconds and over the session, against the
    machine's floor when the sim process measured it (else against ON_TIME_TARGET); a figure
    below the target (the floor less BELOW_FLOOR_ALLOWED) is bold."""
    floor = (loop.get("floor") or {}).get("on_time_fraction")
    wanted = ON_TIME_TARGET if floor is None else floor - BELOW_FLOOR_ALLOWED

    def figure(fraction: float) -> str:
        if not math.isfinite(fraction):  # a recording of a headless run has no loop
            return "–"
        text = f"{100.0 * fraction:.1f} %"
        return f"**{text}**" if fraction < wanted else text

    session = figure(loop.get("on_time_fraction", math.nan))
    recent = "–" if window is None else figure(window.on_time_fraction)
    seconds = WINDOW_S if window is None else window.seconds
    text = f"on-time {recent} last {seconds:.0f} s, {session} session"
    if floor is not None:
        return f"{text} (this machine's floor {100 * floor:.1f} %)"
    below = window is not None and window.on_time_fraction < ON_TIME_TARGET
    return f"{text} (target {100 * ON_TIME_TARGET:g} %)" if below else text


def status_markdown(
    tel: dict,
    rtf: float,
    fps: float,
    control_us: float | None = None,
    loop: LoopWindow | None = None,
    run_rtf: float = math.nan,
) -> str:
    """The status line for one telemetry message: `rtf` over the last seconds, `run_rtf` since
    this run (robot, scene, reset) began, `loop` the loop's recent deadline figures."""
    qp = tel["qp"]
    # what computed the tick; in a recording made before `ran` existed, what was asked
    ran = tel.get("ran") or {**tel["hierarchy"], "kernel": tel.get("kernel", "?")}
    method = ran["method"]
    if method == "nullspace":
        method += f" ({ran['formulation']})"
    flags = " · **paused**" if tel["paused"] else ""
    warnings = warnings_of(tel, control_us, rtf, loop)
    shown_us = qp["solve_us"] if control_us is None else control_us
    text = (
        f"**{tel['robot']}** on {tel['scene']} · {tel['gait']} · {method}/"
        f"{ran['solver']} · {ran['kernel']} kernel{flags}  \n"
        f"t {tel['t']:.2f} s · RTF {_rtf(rtf)} last {WINDOW_S:.0f} s, {_rtf(run_rtf)} "
        f"run · {on_time_text(tel.get('loop', {}), loop)} · "
        f"{control_text(tel, shown_us, warnings)} · failures {qp['failures']} · view {fps:.0f} fps"
    )
    # always a third line: the panel below must not jump as warnings come and go
    text += "  \n⚠ " + " · ".join(warnings.values()) if warnings else "  \nno warnings"
    return text


def _rtf(value: float) -> str:
    """A real-time factor, bold below SLOW_RTF."""
    if not math.isfinite(value):
        return "–"
    return f"**{value:.2f}**" if value < SLOW_RTF else f"{value:.2f}"


class RealtimeFactor:
    """Sim time over wall time across the last `window_s` of telemetry (`value`) and since the
    run began (`run_value`). A sim clock that goes back (reset) or a new robot or scene starts
    a new run instead of mixing the two clocks (which read −173 right after a reset)."""

    def __init__(self, window_s: float = WINDOW_S) -> None:
        self.window_s = window_s
        self._samples: list[tuple[float, float]] = []  # (wall s, sim s)
        self._first: tuple[float, float] | None = None  # the run's first sample
        self._key: tuple | None = None

    def add(self, wall: float, sim_t: float, key: tuple = ()) -> None:
        """One telemetry message received at `wall` (monotonic s), of sim time `sim_t`; `key`
        names the run (robot, scene): a new key restarts the window."""
        if key != self._key or (self._samples and sim_t < self._samples[-1][1]):
            self._samples.clear()
            self._key = key
            self._first = (wall, sim_t)
        self._samples.append((wall, sim_t))
        while len(self._samples) > 2 and self._samples[0][0] < wall - self.window_s:
            self._samples.pop(0)

    def value(self) -> float:
        """NaN until two messages of one run have arrived."""
        if len(self._samples) < 2:
            return math.nan
        return _ratio(self._samples[0], self._samples[-1])

    def run_value(self) -> float:
        """Since the run began; NaN until two messages of it have arrived."""
        if self._first is None or len(self._samples) < 2:
            return math.nan
        return _ratio(self._first, self._samples[-1])


def _ratio(first: tuple[float, float], last: tuple[float, float]) -> float:
    """Sim time over wall time between two (wall s, sim s) samples."""
    (w0, t0), (w1, t1) = first, last
    return (t1 - t0) / (w1 - w0) if w1 > w0 else math.nan


class LiveStatus:
    """The status line's figures over the last seconds, fed every telemetry message: the
    controller's typical time per tick (median of the last CONTROL_WINDOW), the real-time factor
    and the loop's deadline figures."""

    def __init__(self) -> None:
        self.rtf = RealtimeFactor()
        self.loop = LoopFigures()
        self._control_us: deque[float] = deque(maxlen=CONTROL_WINDOW)

    def add(self, tel: dict) -> None:
        """One telemetry message (any, for the controller's time)."""
        self._control_us.append(tel["qp"]["solve_us"])

    def add_newest(self, wall: float, tel: dict, run: tuple, live: bool = True) -> None:
        """The newest message of a batch, received at `wall` (monotonic s), of run `run`.

        A `live` lab's message is placed at the loop's own clock when it was built (`loop`'s
        `clock_s`), not at when the page received it: a UI process starved of CPU receives
        telemetry in bursts, and timed by receipt the page showed 0.28× real time and 1.9 % on
        time over "the last 5 s" while the loop's own counters gave 0.99× and 69 % over the same
        seconds (benchmarks/bench_status_line.py, load 37). A recording served by `lab replay
        --serve` (`live` False) is timed by receipt: its playback speed is the rate to show."""
        clock = tel.get("loop", {}).get("clock_s") if live else None
        when = wall if clock is None else clock
        self.rtf.add(when, tel["t"], run)
        self.loop.add(when, tel.get("loop", {}))

    def control_us(self) -> float | None:
        return statistics.median(self._control_us) if self._control_us else None

    def warnings(self, tel: dict) -> dict:
        """`warnings_of` with the recent figures."""
        return warnings_of(tel, self.control_us(), self.rtf.value(), self.loop.window())

    def markdown(self, tel: dict, fps: float) -> str:
        """`status_markdown` with the recent figures."""
        window = self.loop.window()
        return status_markdown(
            tel, self.rtf.value(), fps, self.control_us(), window, self.rtf.run_value()
        )
