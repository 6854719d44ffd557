"""The machine's floor, measured by the loop itself (issue 31): the share of ticks the same
loop thread, with the same scheduling and wake-up settings, gets on time with nothing to do
between deadlines. On a virtual machine part of the late ticks is the host's (a halted vCPU
woken late, a running one taken away); the server's on-time fraction is read against this
floor, measured in the same process at start-up (`lab serve --floor-s`) and on demand (the
`floor` command). Meanwhile the session stands still and commands wait."""

import threading

from lab.runtime.deadline_stats import ON_TIME_TOLERANCE, DeadlineStats, us_summary


class FloorRun:
    """One floor measurement at a time: `start` it, feed every tick of the empty loop to
    `record` until it says it is done; `result` then holds the figures, `finished` is set."""

    def __init__(self, period: float) -> None:
        self.period = period
        self.stats: DeadlineStats | None = None  # the run under way, if any
        self.result: dict[str, object] | None = None  # the last run's figures
        self.request: object = None  # the `floor` command to answer at the end, if any
        self.finished = threading.Event()  # set when a run ends
        self._seconds = 0.0
        self._until: float | None = None

    @property
    def running(self) -> bool:
        return self.stats is not None

    def start(self, seconds: float, request: object) -> None:
        """Measure for `seconds` from the next tick; answer `request` (None: nobody) at the end."""
        if seconds <= 0.0:
            raise ValueError(f"floor: seconds must be positive, got {seconds!r}")
        self.stats = DeadlineStats(self.period, realtime=True)
        self.request = request
        self._seconds, self._until = seconds, None
        self.finished.clear()

    def record(self, now: float, lateness: float, work: float, overrun: bool) -> bool:
        """One empty tick that started at `now`; True when the run has ended with it."""
        stats = self.stats
        if stats is None:
            raise RuntimeError("floor: no measurement under way")
        if self._until is None:
            self._until = now + self._seconds
        stats.record(lateness, work, overrun)
        if now < self._until:
            return False
        self.result = {
            "on_time_fraction": stats.on_time / stats.ticks,
            "ticks": stats.ticks,
            "seconds": self._seconds,
            "late_wakeups": stats.late_wakeups,
            "late_pushed": stats.late_pushed.total,
            "lateness_us": us_summary(stats.lateness),
            "tolerance_us": round(ON_TIME_TOLERANCE * self.period * 1e6, 1),
            "clock_s": now,
        }
        self.stats = None
        self.finished.set()
        return True
