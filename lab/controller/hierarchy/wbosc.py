"""Whole-Body Operational Space Control (Kim 2016 App. A; Sentis 2007, 2010): closed form, no QP.

The feet in support are held still by the contact-consistent dynamics (eqs. 28–32), so the
torques alone decide q̈ and the reaction forces. Over the actuated torques τ:
- each level's motion rows J q̈ = b (a task's J q̈ + J̇v = a_des) become J* Φ* τ = b − J q̈₀ with
  the contact-consistent Jacobian J* = J (U N_s)‾ (eq. 33); the levels are prioritized in
  Sentis's dynamically consistent way: τ ← τ + J*_{k|p}ᵀ Λ*_{k|p} (b_k − J_k q̈(τ)) with
  J*_{k|p} = J*_k N*_p, Λ*_{k|p} = (J*_{k|p} Φ* J*_{k|p}ᵀ)⁺ and N*_p ← N*_p − Φ* J*_{k|p}ᵀ Λ*_{k|p}
  J*_{k|p}. With the task's a_des this is F_task = Λ*(u − J̇v) + μ* + p* (eq. 35): the bias
  forces enter through q̈₀.
- rows over the forces only (the `internal_force` task W_int λ = F_int,cmd, the `forces`
  regularizer) are met by torques in the null space of Φ*, which move nothing (L*, eq. 38):
  τ_int = Z w with the smallest w solving them in least squares, in priority order. For one
  internal-force row this is Γ_int = J*_{i|l}ᵀ (F_int,cmd − F_int,{t} + μ_i + p_i) of eq. 43:
  F_int,{t} − μ_i − p_i is the internal force the motion torques already make.
Rows over both q̈ and F (the `torques` task) have no place in this structure: `check_stack`
refuses them. Inequalities are not enforced: they are evaluated at the result, and each one
that does not hold (a foot that would pull, leave its friction cone, a torque over its limit) is
reported in the solution's `violations` (status `violated`); the torques are sent as they are.
"""

from collections.abc import Iterable

import numpy as np

from lab.controller.contact_dynamics import ContactDynamics, contact_dynamics, psd_pinv
from lab.controller.hierarchy.problem import HierarchyProblem, Level
from lab.controller.hierarchy.solution import (
    EXACT,
    NO_FREEDOM,
    HierarchySolution,
    LevelClock,
    level_residuals,
)

# Tasks whose rows mix q̈ and F: no operational-space form, refused.
REFUSED_TASKS = {"torques": "its rows τ(x) = 0 mix q̈ and F"}
# An inequality row is reported when C x − d exceeds this (in the row's units: N, N m, rad/s²).
VIOLATION_TOLERANCE = 1e-6


class WboscStackError(ValueError):
    """A stack names a task that wbosc cannot realize."""


def check_stack(names: Iterable[str]) -> None:
    """Raise WboscStackError naming every task of the stack wbosc refuses, and why."""
    refused = [f"{name!r} ({REFUSED_TASKS[name]})" for name in names if name in REFUSED_TASKS]
    if refused:
        raise WboscStackError(
            "wbosc cannot realize " + ", ".join(refused) + ": it takes motion tasks (rows over "
            "q̈), force tasks over F (internal_force, forces) and reports every constraint"
        )


def solve_wbosc(problem: HierarchyProblem, solver: str = "") -> HierarchySolution:
    """x = [q̈, F] from the WBOSC torques (module docstring); `solver` is unused (no QP).

    A foot in a contact transition (`terms.transition` w ∈ [0, 1], Kim §III-F) leaves the
    contact set; the force it would carry in dual contact, from a first solve with it in
    (eq. 10), is applied to it scaled by w as a known external force (eq. 9)."""
    terms = problem.terms
    if terms is None or terms.drift is None:
        raise ValueError("wbosc needs the dynamics terms M, h, J_c and J̇_c v in the problem")
    clock = LevelClock(len(problem.levels))
    nv = terms.M.shape[0]
    support = np.flatnonzero(terms.support)
    bias = terms.h
    leaving = np.zeros(0, dtype=int)
    external = np.zeros(0)
    if terms.transition is not None:
        changing = terms.support & np.isfinite(terms.transition)
        if np.any(changing):
            dual = _solve(
                problem,
                contact_dynamics(terms.M, bias, terms.Jc[support], terms.drift[support]),
                support,
                clock,
            )
            leaving = np.flatnonzero(changing)
            external = terms.transition[leaving] * dual.x[nv + leaving]  # f = w f_dual (eq. 9–10)
            bias = bias - terms.Jc[leaving].T @ external
            support = np.flatnonzero(terms.support & ~changing)
    dyn = contact_dynamics(terms.M, bias, terms.Jc[support], terms.drift[support])
    solution = _solve(problem, dyn, support, clock)
    if len(leaving):
        x = solution.x.copy()
        x[nv + leaving] = external
        solution = HierarchySolution(
            x,
            solution.levels,
            level_residuals(problem.levels, x),
            level_seconds=tuple(clock.seconds),
            violations=tuple(_violations(problem.levels, x)),
        )
    return solution


def _solve(
    problem: HierarchyProblem, dyn: ContactDynamics, support: np.ndarray, clock: LevelClock
) -> HierarchySolution:
    """The WBOSC torques for the contact-consistent dynamics `dyn` of the rows `support` of F,
    and the x they give."""
    nv = dyn.qdd_of_torque.shape[0]
    na = dyn.phi.shape[0]
    # A level with rows but no freedom left for any of them is `no_freedom`.
    with_rows = {k for k, level in enumerate(problem.levels) if len(level.b)}
    moved: set[int] = set()

    # Motion levels, highest priority first (Sentis's prioritized WBOSC).
    tau = np.zeros(na)
    null = np.eye(na)  # N*_p
    force_levels = []
    for k, level in enumerate(problem.levels):
        motion, force = _split(level, nv, k)
        if force is not None:
            force_levels.append((k, force))
        if motion is not None:
            J, b = motion
            J_star = dyn.contact_consistent_jacobian(J)
            J_prior = J_star @ null  # J*_{k|p}
            scale = float(np.trace(J @ dyn.inertia_inverse @ J.T))  # the unconstrained task's
            Lambda, rank = psd_pinv(J_prior @ dyn.phi @ J_prior.T, scale)  # Λ*_{k|p}
            if rank:
                moved.add(k)
                error = b - J @ (dyn.qdd_of_torque @ tau + dyn.qdd_free)
                tau = tau + J_prior.T @ (Lambda @ error)
                null = null - dyn.phi @ J_prior.T @ Lambda @ J_prior
        clock.lap(k)

    # Force levels in the internal-force torques (null space of Φ*, eq. 38–43).
    Z = dyn.internal_basis
    room = np.eye(Z.shape[1])
    w = np.zeros(Z.shape[1])
    for k, (A_F, b) in force_levels:
        A_s = A_F[:, support]
        full = A_s @ dyn.force_of_torque  # how every torque moves these forces
        sensitivity = full @ Z @ room
        gram_inv, rank = psd_pinv(sensitivity.T @ sensitivity, float(np.sum(full * full)))
        if rank == 0:
            continue
        moved.add(k)
        error = b - A_s @ (dyn.force_of_torque @ (tau + Z @ w) + dyn.force_free)
        step = room @ gram_inv @ sensitivity.T @ error
        w = w + step
        room = room @ (np.eye(room.shape[1]) - gram_inv @ sensitivity.T @ sensitivity)
        clock.lap(k)
    tau = tau + Z @ w

    x = np.zeros(problem.nx)
    x[:nv] = dyn.qdd_of_torque @ tau + dyn.qdd_free
    x[nv + support] = dyn.force_of_torque @ tau + dyn.force_free
    return HierarchySolution(
        x,
        tuple(NO_FREEDOM if k in with_rows - moved else EXACT for k in range(len(problem.levels))),
        level_residuals(problem.levels, x),
        level_seconds=tuple(clock.seconds),
        violations=tuple(_violations(problem.levels, x)),
    )


def _split(
    level: Level, nv: int, index: int
) -> tuple[tuple[np.ndarray, np.ndarray] | None, tuple[np.ndarray, np.ndarray] | None]:
    """The level's rows over q̈ only and over F only; a row over both is a ValueError."""
    if not len(level.b):
        return None, None
    on_qdd = np.any(level.A[:, :nv] != 0.0, axis=1)
    on_force = np.any(level.A[:, nv:] != 0.0, axis=1)
    if np.any(on_qdd & on_force):
        raise ValueError(f"wbosc: level {index} has rows over both q̈ and F")
    motion = (level.A[on_qdd, :nv], level.b[on_qdd]) if np.any(on_qdd) else None
    force = (level.A[on_force, nv:], level.b[on_force]) if np.any(on_force) else None
    return motion, force


def _violations(levels: list[Level], x: np.ndarray) -> list[str]:
    """One line per constraint of the stack with a row C x − d above tolerance."""
    found = []
    for k, level in enumerate(levels):
        if not len(level.d):
            continue
        excess = level.C @ x - level.d
        names = level.constraint_rows or (("inequalities", len(level.d)),)
        start = 0
        for name, count in names:
            worst = float(np.max(excess[start : start + count], initial=-np.inf))
            if worst > VIOLATION_TOLERANCE:
                found.append(f"level {k} {name}: exceeded by {worst:.3g}")
            start += count
    return found
