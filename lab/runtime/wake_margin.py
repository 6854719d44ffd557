"""The adaptive wake-up margin (issue 31): how long before a deadline the loop asks to be woken,
learned from how late its own sleeps have ended.

A sleep until `deadline - margin` ends some time after it was asked to (the host wakes a halted
vCPU in 35-50 µs at the median here, far later in its tail on a loaded host); the loop spins
from there to the deadline. A fixed short margin misses the tail's ticks; spinning the whole
period catches them and keeps a CPU busy. This margin is a high percentile (p99.5) of the
oversleep over the last WINDOW wake-ups, so the loop spins only for as long as its wake-ups
have recently needed, and follows the host as it gets slower or quicker. The window counts
ticks, not only sleeps: a loop that no longer sleeps (work that overran, a margin longer than
what is left of the period after the tick) learns nothing, so once fewer than MIN_SAMPLES of
the last WINDOW ticks slept it goes back to INITIAL_MARGIN_S and tries again.
"""

from bisect import bisect_left
from collections import deque
from itertools import accumulate

from lab.runtime.deadline_stats import LogHistogram

PERCENTILE = 99.5  # the oversleep the margin covers
WINDOW = 2000  # ticks the percentile is taken over (2 s at 1 kHz)
MIN_SAMPLES = 200  # with fewer sleeps in the window, the initial margin
MIN_MARGIN_S = 2e-5  # never ask to be woken closer to the deadline than this
# Nor further than this share of the period: on a host whose tail of wake-ups is that slow (a
# loaded one: p99.5 beyond 1 ms at load 12 on 2 cores) a longer spin is CPU time EEVDF charges
# the loop with, and it was late more often, not less (docs/performance.md, "Why the loop is
# built this way").
MAX_MARGIN_SHARE = 0.5
NO_SLEEP = -1  # in the window: a tick that did not sleep
INITIAL_MARGIN_S = 3e-4  # while the window holds fewer than MIN_SAMPLES sleeps


class WakeMargin:
    """The margin (s) the loop wakes before each deadline: PERCENTILE of the oversleeps of the
    last WINDOW ticks (`record` for a tick that slept, `no_sleep` for one that did not),
    refreshed by `update` (a pass over LogHistogram's bins: not every tick), within
    MIN_MARGIN_S..MAX_MARGIN_SHARE of the period."""

    def __init__(self, period: float) -> None:
        self.period = period
        self.longest = MAX_MARGIN_SHARE * period
        self.seconds = min(INITIAL_MARGIN_S, self.longest)
        self._counts = [0] * (LogHistogram.BINS + 1)
        self._window: deque[int] = deque()  # bin of each tick's oversleep, NO_SLEEP if none
        self._samples = 0  # ticks in the window that slept

    def record(self, oversleep: float) -> None:
        """One sleep ended `oversleep` s after the time it was asked to end."""
        index = bisect_left(LogHistogram.EDGES, oversleep)
        self._counts[index] += 1
        self._samples += 1
        self._push(index)

    def no_sleep(self) -> None:
        """A tick that did not sleep (its wake-up time had passed): nothing learned."""
        self._push(NO_SLEEP)

    def _push(self, index: int) -> None:
        self._window.append(index)
        if len(self._window) > WINDOW:
            old = self._window.popleft()
            if old != NO_SLEEP:
                self._counts[old] -= 1
                self._samples -= 1

    def update(self) -> float:
        """Recompute the margin from the window (the upper edge of the percentile's bin: 5 %
        above it at most); returns it."""
        if self._samples < MIN_SAMPLES:
            self.seconds = min(INITIAL_MARGIN_S, self.longest)
            return self.seconds
        cumulative = list(accumulate(self._counts))
        index = bisect_left(cumulative, PERCENTILE / 100.0 * self._samples)
        high = LogHistogram.EDGES[index] if index < LogHistogram.BINS else self.longest
        self.seconds = min(self.longest, max(MIN_MARGIN_S, high))
        return self.seconds
