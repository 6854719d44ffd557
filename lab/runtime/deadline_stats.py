"""The loop's deadline statistics: when each tick started against its deadline, how long its
work took (by what it did beside the session's tick), which late ticks were woken late by the
host and which were pushed by the loop's own overrun, and the garbage collector's pauses; kept
in log histograms cheap enough to record every tick."""

import contextlib
import gc
import time
from bisect import bisect_left
from itertools import accumulate

ON_TIME_TOLERANCE = 0.1  # a tick is on time if it starts <= 10 % of a period after its deadline
# What the loop did beside the tick: nothing, build telemetry, build the drawing state, publish
# one of them, refresh the statistics' percentiles.
TICK_KINDS = ("plain", "telemetry", "state", "publish", "stats")


def _geometric_edges(low: float, ratio: float, count: int) -> list[float]:
    """low, low·ratio, …, low·ratio^(count-1)."""
    return [low * ratio**i for i in range(count)]


class LogHistogram:
    """Counts of positive durations in geometric bins (5 % wide from 0.1 µs to 10 s); cheap to
    record every tick, percentiles read as the upper edge of the bin.

    Both are C calls on a list, not Python arithmetic: a record is one `bisect` over the bin
    edges (the log, division and `min` it replaced cost ~1 µs a record, three records a tick), a
    percentile one `accumulate` and one `bisect` (a Python pass over the bins cost ~0.1 ms a
    percentile in the server, six at every refresh: `git show fe8d29c:docs/performance.md`,
    round 10)."""

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
            target[key] = us_summary(histogram)

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
        target[key] = us_summary(histogram)

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
            "late_pushed": self.late_pushed.total,
            "skipped": self.skipped,
            "slice_us": self.slice_us,
            "nice": self.nice,
            "gc_collections": list(self.gc.counts),
            **self._details,
        }


def us_summary(h: LogHistogram) -> dict[str, float]:
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
