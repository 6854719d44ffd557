"""Momentum feedback of Herzog 2016 §3: a desired rate of change of the centroidal momentum.

The state is s = [c − c_ref; h_lin − h_lin,ref; h_ang − h_ang,ref] (CoG position error, then the
linear and angular momentum errors about the CoG, world axes) and the momentum task asks
ḣ_des = −K_h s + ḣ_ref, K_h a 6 × 9 gain in momentum space:

- `pd` (eq. 22): diagonal gains,
  ḣ_des = [kp m (c_ref − c) + kd (h_ref − h)_lin; kd (h_ref − h)_ang].
- `lqr` (eqs. 21, 23–26): the momentum dynamics of eq. 21 linearized about the current contact
  configuration, ċ = h_lin / m, ḣ_lin = Σ δf_i, ḣ_ang = Σ (p_i − c) × δf_i + δτ_i + [F₀]× δc
  (F₀ = Σ f_i⁰ = −m g, which couples the CoG offset to the angular momentum), with the contact
  forces' deviations δλ from the static distribution as the inputs. The infinite-horizon
  Riccati equation (scipy) gives δλ = −K s (eq. 23); projected into momentum space through the
  contact map G (eq. 24) the rate it asks is ḣ = G(λ⁰ + δλ) − m g = [F₀]× δc − G K s: the
  static forces' moment about the displaced CoG is part of eq. 24's feedforward k. So
  K_h = G K − A_h (A_h the momentum rows of A), and the closed loop the robot follows is the
  designed A − B K. The redundancy of the contact forces stays free for the tasks below, as
  the paper intends.
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import pinocchio as pin
import scipy.linalg

from lab.controller.model import RobotModel

# Herzog 2016 §5.2.2, eq. 26: the cost on [c; h_lin; h_ang] and on each contact's force, torque.
HERZOG_Q = (30.0, 30.0, 50.0, 0.5, 0.5, 0.5, 0.1, 0.1, 0.1)
HERZOG_R = (0.1, 0.1, 0.01, 2.0, 2.0, 2.0)


@dataclass(frozen=True)
class LqrCost:
    """Diagonal weights of eq. 26: Q on the 9 states, R on a contact's force (3) and torque (3)."""

    Q: tuple[float, ...] = HERZOG_Q
    R: tuple[float, ...] = HERZOG_R


# The LQR modes and their costs: `lqr` is eq. 26's cost as printed; `lqr_talos` is the same cost
# retuned for Talos by the paper's own recipe (fast damping of momentum, a slight preference
# for the linear part, §5.2.2): the momentum weights ×10 and the contact costs ÷10 against the
# CoG's. The CoG weight hardly matters (the [F₀]× coupling dominates the design); what sets the
# response is momentum against force: with the printed cost Talos's CoG is held at 1.3 kN/m
# with 7.5 /s of damping, with this one at 4.0 kN/m and 32 /s (docs/replications.md, Herzog).
LQR_COSTS: dict[str, LqrCost] = {
    "lqr": LqrCost(),
    "lqr_talos": LqrCost(
        Q=(30.0, 30.0, 50.0, 5.0, 5.0, 5.0, 1.0, 1.0, 1.0), R=(0.01, 0.01, 0.001, 0.2, 0.2, 0.2)
    ),
}
MOMENTUM_MODES = ("pd", *LQR_COSTS)
# m: an LQR gain is designed again when an arm p_i − c of a contact in support has moved this far
# from the pose it was designed at (GainSchedule; the choice is measured in docs/controller.md).
ARM_TOLERANCE = 0.02


def pd_gain(mass: float, kp: float, kd: float) -> np.ndarray:
    """K_h of eq. 22 with diagonal gains: −K_h s = [kp m Δc + kd Δh_lin; kd Δh_ang]."""
    K = np.zeros((6, 9))
    K[:3, :3] = kp * mass * np.eye(3)
    K[:3, 3:6] = kd * np.eye(3)
    K[3:, 6:] = kd * np.eye(3)
    return K


def contact_map(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """G (6 × nf): the wrench about the CoG, world axes, of the contact forces F (zero columns for
    contacts out of support). A flat foot's wrench is in its sole frame at the sole centre."""
    G = np.zeros((6, robot.nf))
    for i, (contact, rows) in enumerate(zip(robot.contacts, robot.force_slices, strict=True)):
        if not active[i]:
            continue
        arm = pin.skew(robot.contact_positions[i] - robot.com)
        R = np.eye(3) if contact.kind == "point" else robot.contact_rotations[i]
        G[:3, rows.start : rows.start + 3] = R
        G[3:, rows.start : rows.start + 3] = arm @ R
        if contact.kind == "flat":
            G[3:, rows.start + 3 : rows.stop] = R
    return G


@dataclass(frozen=True)
class LqrProblem:
    """The LQR of eq. 21 linearized at one state, as plain arrays (a snapshot: it can be solved
    anywhere, another process included): ṡ = A s + B δλ, cost sᵀQs + δλᵀRδλ (eq. 26)."""

    A: np.ndarray
    B: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    supported: tuple[str, ...]  # the contacts in support, for error messages


@dataclass(frozen=True)
class LqrDesign:
    """The linearized momentum dynamics ṡ = A s + B δλ (eq. 21), the Riccati solution P (cost to
    go sᵀ P s), the force feedback δλ = −K s (eq. 23) and the momentum-space gain
    K_h = G K − A_h of ḣ_des = −K_h s, under which ṡ = (A − B K) s (eq. 24)."""

    A: np.ndarray
    B: np.ndarray
    P: np.ndarray
    K: np.ndarray
    momentum_gain: np.ndarray


def lqr_problem(robot: RobotModel, active: np.ndarray, cost: LqrCost) -> LqrProblem:
    """Eq. 21 linearized at the current state (the contact configuration `active` and its pose)
    with the cost of eq. 26. Raises LinAlgError where no contact is in support."""
    G = contact_map(robot, active)
    columns = np.flatnonzero(np.any(G != 0.0, axis=0))
    if columns.size == 0:
        raise np.linalg.LinAlgError("no LQR momentum gain without a contact in support")
    B = np.zeros((9, len(columns)))
    B[3:] = G[:, columns]
    A = np.zeros((9, 9))
    A[:3, 3:6] = np.eye(3) / robot.mass
    A[6:, :3] = pin.skew(-robot.mass * robot.gravity)  # [F₀]×: ∂ḣ_ang/∂c
    R = np.diag(_force_costs(robot, active, cost))
    supported = tuple(c.name for c, on in zip(robot.contacts, active, strict=True) if on)
    return LqrProblem(A, B, np.diag(cost.Q), R, supported)


def solve_lqr(problem: LqrProblem) -> LqrDesign:
    """The infinite-horizon LQR of `problem` (scipy's Riccati solver). Raises LinAlgError,
    naming the contacts, where no stabilizing gain exists."""
    A, B, R = problem.A, problem.B, problem.R
    try:
        P = scipy.linalg.solve_continuous_are(A, B, problem.Q, R)
    except (np.linalg.LinAlgError, ValueError) as error:
        raise np.linalg.LinAlgError(
            f"no stabilizing LQR momentum gain on the contacts {list(problem.supported)}: {error}"
        ) from error
    K = np.linalg.solve(R, B.T @ P)
    return LqrDesign(A, B, P, K, B[3:] @ K - A[3:])


def momentum_gain_of(problem: LqrProblem) -> np.ndarray:
    """K_h of `problem`'s LQR: what a worker computes off the loop (`GainSchedule.submit`)."""
    return solve_lqr(problem).momentum_gain


def lqr_design(robot: RobotModel, active: np.ndarray, cost: LqrCost) -> LqrDesign:
    """The infinite-horizon LQR of eq. 21 linearized at the current state (the contact
    configuration `active` and its pose), for the cost of eq. 26. Raises LinAlgError, naming
    the contacts, where no gain exists (no contact in support, or no stabilizing solution)."""
    return solve_lqr(lqr_problem(robot, active, cost))


def contact_arms(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """p_i − c of each contact in support (m, world axes): the pose eq. 24's G reads."""
    return robot.contact_positions[active] - robot.com


def _force_costs(robot: RobotModel, active: np.ndarray, cost: LqrCost) -> np.ndarray:
    """R's diagonal over the active contacts' force rows: force then torque of each."""
    pairs = zip(robot.contacts, active, strict=True)
    return np.concatenate([cost.R[: contact.force_dim] for contact, on in pairs if on])


class GainFuture(Protocol):
    """A design running elsewhere (concurrent.futures.Future has these)."""

    def done(self) -> bool: ...

    def result(self) -> np.ndarray: ...


@dataclass
class GainSchedule:
    """K_h per contact configuration, designed at the configuration's pose and designed again
    when an arm p_i − c of a contact in support has moved more than ARM_TOLERANCE since (a step,
    a reset, the squat's CoG): Herzog's "gains for key poses of the robot, one for each contact
    configuration" (§3.2 remark), kept at the pose eq. 24 reads. After a switch or a redesign
    the gain in use moves to the new one over `transition_ticks` ticks (the command stays
    continuous, as the paper interpolates across a contact switch).

    `submit` (set by the server's session layer, e.g. a worker process's executor) designs off
    the loop: it takes the design problem and returns a future; the gain in use stays until the
    new one arrives (`pending`). Unset, or before any gain exists, a design runs at once."""

    transition_ticks: int = 100  # 0.1 s at 1 kHz
    solve: Callable[[LqrProblem], np.ndarray] = momentum_gain_of  # a design run at once
    submit: Callable[[LqrProblem], GainFuture] | None = None
    designs: int = 0  # gains designed since the schedule was made or cleared
    # bumped whenever a stored design, the pending one or the whole schedule changes: a holder
    # of a settled gain (the native kernel, MomentumTask.to_kernel) sees it changed elsewhere
    version: int = 0
    _gains: dict[bytes, np.ndarray] = field(default_factory=dict)
    _arms: dict[bytes, np.ndarray] = field(default_factory=dict)  # the pose of each gain
    _pending: tuple[bytes, np.ndarray, GainFuture] | None = None
    _current: np.ndarray | None = None
    _previous: np.ndarray | None = None
    _target: np.ndarray | None = None
    _key: bytes = b""
    _ticks: int = 0

    def _moved(self, key: bytes, arms: np.ndarray) -> bool:
        designed = self._arms.get(key)
        return designed is None or np.abs(arms - designed).max(initial=0.0) > ARM_TOLERANCE

    def _install(self, key: bytes, arms: np.ndarray, gain: np.ndarray) -> None:
        self._gains[key], self._arms[key] = gain, arms.copy()
        self.designs += 1
        self.version += 1

    def target(self, key: bytes, arms: np.ndarray, problem: Callable[[], LqrProblem]) -> np.ndarray:
        """K_h of configuration `key` at the pose `arms` (contact_arms), the gain the
        interpolation ends at: designed when none is stored or the stored one's pose is more
        than ARM_TOLERANCE away (off the loop when `submit` is set and a gain is in use: the
        stored one, or the one in use, serves until it arrives)."""
        pending = self._pending
        if pending is not None and pending[2].done():
            self._pending = None
            self.version += 1
            self._install(pending[0], pending[1], pending[2].result())  # raises its LinAlgError
        if self._moved(key, arms):
            if self.submit is None or self._current is None:
                self._install(key, arms, self.solve(problem()))
            elif self._pending is None:  # one design at a time: the newest pose goes next
                self._pending = (key, arms.copy(), self.submit(problem()))
                self.version += 1
        return self._gains.get(key, self._target)

    def gain(self, key: bytes, arms: np.ndarray, problem: Callable[[], LqrProblem]) -> np.ndarray:
        """This tick's K_h for configuration `key` at pose `arms`."""
        target = self.target(key, arms, problem)
        if target is not self._target:  # a switch, a redesign, or the design that arrived
            self._target, self._key = target, key
            if self._current is None:  # the first gain: nothing to move from
                self._current, self._ticks = target, self.transition_ticks
                return target
            self._previous, self._ticks = self._current, 0
        if self._ticks < self.transition_ticks:
            self._blend_at(self._ticks + 1)
        return self._current

    def _blend_at(self, steps: int) -> None:
        """The blend's K_h after `steps` steps: (1 − α) from + α to, α = steps /
        transition_ticks, the target itself at the last (native: MomentumTask::step_blend)."""
        before, target = self._previous, self._target
        assert before is not None and target is not None
        self._ticks = steps
        alpha = steps / self.transition_ticks
        done = steps == self.transition_ticks
        self._current = target if done else (1.0 - alpha) * before + alpha * target

    def settled(self, key: bytes, arms: np.ndarray) -> bool:
        """Whether `gain(key, arms, …)` keeps its target (same configuration and pose, no design
        running): a caller holding the target may skip `gain`, stepping the interpolation to it
        itself (`blend`, `skip`)."""
        return self.held_arms(key) is not None and not self._moved(key, arms)

    def held_arms(self, key: bytes) -> np.ndarray | None:
        """The pose (contact_arms) that configuration `key`'s gain was designed at, when the gain
        in use is that one or is moving to it (`blend`) and no design runs; else None. A holder
        may skip `gain` while the configuration is `key` and no arm has moved more than
        ARM_TOLERANCE from this pose (`settled`), until `version` changes, stepping the blend
        as `gain` does and telling `skip` how many steps it made."""
        if (
            self._current is None
            or self._pending is not None
            or self._target is not self._gains.get(key)
        ):
            return None
        return self._arms[key]

    def blend(self) -> tuple[np.ndarray, np.ndarray, int, int] | None:
        """The interpolation in progress, (from, to, steps made, transition_ticks): each `gain`
        makes one more step, K_h = (1 − α) from + α to with α = steps / transition_ticks; None
        when the gain in use is its target."""
        if self._current is None or self._ticks >= self.transition_ticks:
            return None
        assert self._previous is not None and self._target is not None
        return self._previous, self._target, self._ticks, self.transition_ticks

    def skip(self, steps: int) -> None:
        """`steps` calls of `gain` with the target kept, made by a holder that stepped the blend
        itself (the native kernel): the same K_h as those calls give, as the blend's K_h depends
        on its step count only."""
        if steps > 0 and self._current is not None and self._ticks < self.transition_ticks:
            self._blend_at(min(self.transition_ticks, self._ticks + steps))

    @property
    def current(self) -> np.ndarray | None:
        """The K_h the last `gain` returned (None before the first, or after `clear`)."""
        return self._current

    def in_use(self) -> dict:
        """Which gain is in use (telemetry's `momentum_control.gain`): the contact configuration
        it was designed for (flags, from the key), whether it is still blending in, whether a
        design is running off the loop, and how many were designed."""
        return {
            "configuration": np.frombuffer(self._key, dtype=bool).tolist(),
            "blending": self._ticks < self.transition_ticks,
            "pending": self._pending is not None,
            "designs": self.designs,
        }

    def clear(self) -> None:
        """Forget every configuration's gain (the cost or the robot changed)."""
        self._gains.clear()
        self._arms.clear()
        self._current = self._previous = self._target = None
        self._pending = None
        self._key = b""
        self._ticks = 0
        self.version += 1
