"""The status line: what runs (the robot of the telemetry, not a remembered one; the kernel,
method, solver and formulation that computed the tick, telemetry's `ran`), how fast, the tick's
status (ok, fallback, capped, violated, failed) and every warning in effect: a fall, fallback
torques, a status other than ok with its level and reason, ticks slower than the loop period, a
sim slower than real time (pure: tested in tests/test_ui_logic.py)."""

import math

SLOW_RTF = 0.9  # a realtime loop whose sim runs slower than this fraction of real time is warned


def control_budget_us(tel: dict) -> float:
    """The loop period in µs (the controller's budget per tick); 1 ms when unknown."""
    rate = tel.get("loop", {}).get("rate_hz")
    return 1e6 / rate if rate else 1000.0


def status_of(tel: dict) -> dict:
    """Telemetry's `status` (status, level, reason); a recording made before it existed (served
    by `lab replay --serve`) has `qp.status` (ok or failed) instead."""
    return tel.get("status") or {"status": tel["qp"]["status"], "level": None, "reason": ""}


def warnings_of(tel: dict, control_us: float | None = None, rtf: float = math.nan) -> dict:
    """Warnings in effect, by kind: `control_us` is the recent typical controller time per tick
    (default: the last tick's), `rtf` the measured real-time factor."""
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


def status_markdown(tel: dict, rtf: float, fps: float, control_us: float | None = None) -> str:
    """The status line for one telemetry message."""
    loop = tel.get("loop", {})
    qp = tel["qp"]
    # what computed the tick; in a recording made before `ran` existed, what was asked
    ran = tel.get("ran") or {**tel["hierarchy"], "kernel": tel.get("kernel", "?")}
    method = ran["method"]
    if method == "nullspace":
        method += f" ({ran['formulation']})"
    flags = " · **paused**" if tel["paused"] else ""
    warnings = warnings_of(tel, control_us, rtf)
    shown_us = qp["solve_us"] if control_us is None else control_us
    rtf_text = f"{rtf:.2f}" if math.isfinite(rtf) else "–"
    text = (
        f"**{tel['robot']}** on {tel['scene']} · {tel['gait']} · {method}/"
        f"{ran['solver']} · {ran['kernel']} kernel{flags}  \n"
        f"t {tel['t']:.2f} s · RTF {rtf_text} · on-time "
        f"{100.0 * loop.get('on_time_fraction', math.nan):.2f} % · control "
        f"{shown_us:.0f} µs ({qp_state(tel, warnings)}) · failures {qp['failures']} · view "
        f"{fps:.0f} fps"
    )
    # always a third line: the panel below must not jump as warnings come and go
    text += "  \n⚠ " + " · ".join(warnings.values()) if warnings else "  \nno warnings"
    return text


class RealtimeFactor:
    """Sim time over wall time across the last `window_s` of telemetry. A sim clock that goes
    back (reset) or a new robot or scene starts the statistic again instead of mixing the two
    clocks (which read −173 right after a reset)."""

    def __init__(self, window_s: float = 2.0) -> None:
        self.window_s = window_s
        self._samples: list[tuple[float, float]] = []  # (wall s, sim s)
        self._key: tuple | None = None

    def add(self, wall: float, sim_t: float, key: tuple = ()) -> None:
        """One telemetry message received at `wall` (monotonic s), of sim time `sim_t`; `key`
        names the run (robot, scene): a new key restarts the window."""
        if key != self._key or (self._samples and sim_t < self._samples[-1][1]):
            self._samples.clear()
            self._key = key
        self._samples.append((wall, sim_t))
        while len(self._samples) > 2 and self._samples[0][0] < wall - self.window_s:
            self._samples.pop(0)

    def value(self) -> float:
        """NaN until two messages of one run have arrived."""
        if len(self._samples) < 2:
            return math.nan
        (w0, t0), (w1, t1) = self._samples[0], self._samples[-1]
        return (t1 - t0) / (w1 - w0) if w1 > w0 else math.nan
