"""Parts of the realtime loop: deadman ramp, lateness histogram, event folding, priority."""

import itertools
import os
import threading

import numpy as np
import pytest

from lab.server.commands import VelocityCommand
from lab.server.loop import (
    DEADMAN_RAMP_S,
    DEADMAN_TIMEOUT_S,
    EVENT_INTERVAL_S,
    Deadman,
    EventThrottle,
    LogHistogram,
    request_fifo,
)


def test_deadman_holds_then_ramps_linearly_to_zero() -> None:
    deadman = Deadman()
    deadman.refresh(VelocityCommand(1.0, -0.5, 0.4), now=10.0)
    assert deadman.update(10.0 + DEADMAN_TIMEOUT_S - 1e-3) is None
    halfway = deadman.update(10.0 + DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S / 2)
    assert halfway == pytest.approx(VelocityCommand(0.5, -0.25, 0.2))
    end = deadman.update(10.0 + DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S + 1e-3)
    assert end == VelocityCommand(0.0, 0.0, 0.0)
    assert deadman.update(20.0) is None  # stopped: nothing more to send


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
