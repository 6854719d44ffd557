"""Herzog's LQR momentum gains designed off the loop thread (issue 26 item 2).

A Riccati solve (scipy) costs about a millisecond of Python; in the loop thread it would take a
whole tick, and in another thread of the sim process it would hold the GIL the loop needs. So
`lab serve` designs in one worker process: the momentum task's `GainSchedule` hands it the
design problem (plain arrays, `LqrProblem`) and keeps the gain in use until the new one arrives
(telemetry's `momentum_control.gain.pending`). Headless sessions design at once (reproducible).
"""

import multiprocessing
from concurrent.futures import Future, ProcessPoolExecutor

import numpy as np

from lab.controller.momentum import LqrProblem, momentum_gain_of


class GainDesigner:
    """One worker process that designs LQR momentum gains; `submit` is a GainSchedule's. The
    process starts with the first design (a lab that never runs the LQR law starts none)."""

    def __init__(self) -> None:
        self._pool: ProcessPoolExecutor | None = None

    def submit(self, problem: LqrProblem) -> "Future[np.ndarray]":
        """Start designing `problem`'s K_h; the future's result is it (or raises LinAlgError)."""
        if self._pool is None:
            # forkserver: the worker is not a fork of the threaded sim process
            context = multiprocessing.get_context("forkserver")
            self._pool = ProcessPoolExecutor(max_workers=1, mp_context=context)
        return self._pool.submit(momentum_gain_of, problem)

    def close(self) -> None:
        """Stop the worker, if one started (a design still running is dropped)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
