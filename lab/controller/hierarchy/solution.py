"""What every hierarchy method returns: x and how it was found (as TSID's HQPOutput).

The native kernel's `HierarchySolution` (cpp/hierarchy/problem.hpp) has the same fields and the
same level status names, so telemetry reads one shape whichever kernel ran.
"""

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lab.controller.hierarchy.problem import Level

# How a level was solved.
EXACT = "exact"  # least squares of its equalities; no inequality binds
QP = "qp"  # a QP (with slacks under strict priorities; one weighted QP for all levels)
KEPT_ABOVE = "kept_above"  # the solver failed: the level keeps the solution of the levels above
NO_FREEDOM = "no_freedom"  # nothing left in the null space of the levels above
PROJECTED = "projected"  # null-space projection with active inequalities (Hutter §3)
LEVEL_STATUSES = (EXACT, QP, KEPT_ABOVE, NO_FREEDOM, PROJECTED)

# How a tick went, as TSID's HQPOutput status: `ok`; `fallback` (a level's QP failed and it kept
# the solution of the levels above); `capped` (nullspace's active-set search stopped at its cap);
# `violated` (wbosc, which does not enforce inequalities, found one that does not hold); `failed`
# (no solution: the session applied fallback torques).
SOLVE_STATUSES = ("ok", "fallback", "capped", "violated", "failed")


@dataclass(frozen=True)
class SolveStatus:
    """One tick's status (SOLVE_STATUSES), the stack level it concerns (0 = the first; None when
    it concerns no single level) and the reason, '' when ok."""

    status: str
    level: int | None = None
    reason: str = ""

    def report(self) -> dict:
        """JSON-ready: telemetry's `status`."""
        return {"status": self.status, "level": self.level, "reason": self.reason}


SOLVED = SolveStatus("ok")


@dataclass(frozen=True)
class HierarchySolution:
    """x = [q̈, F] (rad/s², m/s² and N, N m) and what happened on the way.

    `levels` has one status per level of the problem (LEVEL_STATUSES), `residuals` the norm
    ‖A x − b‖ of each level's equality rows at x (in the rows' units, √weight included),
    `level_seconds` the time spent on each level (both kernels measure it),
    `qp_solves` how many QPs ran, `capped` whether the nullspace method's active-set search
    stopped at its cap before its optimum, `active_sets` the active rows where each of its
    searches stopped (to start the next tick's from), and `violations` the inequalities a method
    that does not enforce them (wbosc, closed form) found violated at x, one line each.
    """

    x: np.ndarray
    levels: tuple[str, ...]
    residuals: tuple[float, ...]
    qp_solves: int = 0
    level_seconds: tuple[float, ...] = ()
    capped: bool = False
    violations: tuple[str, ...] = ()
    active_sets: tuple[list[np.ndarray], ...] = ()

    @property
    def fallback_levels(self) -> tuple[int, ...]:
        """Indices (0 = the first level of the stack) of the levels whose QP the solver failed,
        which kept the solution of the levels above (the cascade's u = 0)."""
        if KEPT_ABOVE not in self.levels:  # every tick asks; almost every tick has none
            return ()
        return tuple(i for i, status in enumerate(self.levels) if status == KEPT_ABOVE)

    @property
    def status(self) -> str:
        """`ok`, `fallback` (some level kept the solution above), `capped` (nullspace) or
        `violated` (wbosc: an inequality of the stack does not hold, e.g. a foot would pull)."""
        if self.fallback_levels:
            return "fallback"
        if self.capped:
            return "capped"
        return "violated" if self.violations else "ok"

    def solve_status(self) -> SolveStatus:
        """`status` with the level it concerns and why: the first level that fell back, or the
        first a violation names ("level k name: exceeded by x")."""
        status = self.status
        if status == "ok":
            return SOLVED
        if status == "fallback":
            levels = self.fallback_levels
            others = f" (and levels {list(levels[1:])})" if len(levels) > 1 else ""
            return SolveStatus(
                status,
                levels[0],
                f"the QP of level {levels[0]}{others} failed: it keeps the solution of the levels "
                "above",
            )
        if status == "capped":
            return SolveStatus(status, None, "nullspace: the active-set search stopped at its cap")
        level = int(self.violations[0].split()[1])
        return SolveStatus(status, level, "; ".join(self.violations))

    def summary(self) -> dict:
        """JSON-ready fallback levels, level statuses, residuals, QP count and the time
        spent on each level (µs)."""
        return {
            "fallback_levels": list(self.fallback_levels),
            "levels": list(self.levels),
            "residuals": list(self.residuals),
            "qp_solves": self.qp_solves,
            "level_us": [1e6 * s for s in self.level_seconds],
            "violations": list(self.violations),
        }


def level_residuals(levels: Sequence[Level], x: np.ndarray) -> tuple[float, ...]:
    """‖A x − b‖ of each level's equality rows (0 for a level without any)."""
    return tuple(float(np.linalg.norm(lv.A @ x - lv.b)) if len(lv.b) else 0.0 for lv in levels)


class LevelClock:
    """Seconds spent on each level, accumulated over the passes of a method."""

    def __init__(self, n: int) -> None:
        self.seconds = [0.0] * n
        self._start = time.perf_counter()

    def start(self) -> None:
        """Start timing the first level of a pass from now."""
        self._start = time.perf_counter()

    def lap(self, level: int) -> None:
        """Charge the time since the last lap to `level`."""
        now = time.perf_counter()
        self.seconds[level] += now - self._start
        self._start = now
