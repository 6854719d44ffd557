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
class LqrDesign:
    """The linearized momentum dynamics ṡ = A s + B δλ (eq. 21), the Riccati solution P (cost to
    go sᵀ P s), the force feedback δλ = −K s (eq. 23) and the momentum-space gain
    K_h = G K − A_h of ḣ_des = −K_h s, under which ṡ = (A − B K) s (eq. 24)."""

    A: np.ndarray
    B: np.ndarray
    P: np.ndarray
    K: np.ndarray
    momentum_gain: np.ndarray


def lqr_design(robot: RobotModel, active: np.ndarray, cost: LqrCost) -> LqrDesign:
    """The infinite-horizon LQR of eq. 21 linearized at the current state (the contact
    configuration `active` and its pose), for the cost of eq. 26. Raises LinAlgError, naming
    the contacts, where no gain exists (no contact in support, or no stabilizing solution)."""
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
    try:
        P = scipy.linalg.solve_continuous_are(A, B, np.diag(cost.Q), R)
    except (np.linalg.LinAlgError, ValueError) as error:
        supported = [c.name for c, on in zip(robot.contacts, active, strict=True) if on]
        raise np.linalg.LinAlgError(
            f"no stabilizing LQR momentum gain on the contacts {supported}: {error}"
        ) from error
    K = np.linalg.solve(R, B.T @ P)
    return LqrDesign(A, B, P, K, B[3:] @ K - A[3:])


def _force_costs(robot: RobotModel, active: np.ndarray, cost: LqrCost) -> np.ndarray:
    """R's diagonal over the active contacts' force rows: force then torque of each."""
    pairs = zip(robot.contacts, active, strict=True)
    return np.concatenate([cost.R[: contact.force_dim] for contact, on in pairs if on])


@dataclass
class GainSchedule:
    """K_h per contact configuration, computed once per configuration (Herzog §3.2 remark) and
    interpolated over `transition_ticks` ticks after a switch, so the command stays continuous."""

    transition_ticks: int = 100  # 0.1 s at 1 kHz
    _gains: dict[bytes, np.ndarray] = field(default_factory=dict)
    _current: np.ndarray | None = None
    _previous: np.ndarray | None = None
    _key: bytes = b""
    _ticks: int = 0

    def target(self, key: bytes, design: Callable[[], np.ndarray]) -> np.ndarray:
        """K_h of configuration `key`, the one the interpolation ends at; `design()` computes it
        the first time."""
        target = self._gains.get(key)
        if target is None:
            target = self._gains[key] = design()
        return target

    def gain(self, key: bytes, design: Callable[[], np.ndarray]) -> np.ndarray:
        """This tick's K_h for configuration `key`; `design()` computes it the first time."""
        target = self.target(key, design)
        if key != self._key:
            self._previous = self._current if self._current is not None else target
            self._key, self._ticks = key, 0
        self._ticks = min(self._ticks + 1, self.transition_ticks)
        alpha = self._ticks / self.transition_ticks
        self._current = (1.0 - alpha) * self._previous + alpha * target
        return self._current

    def settled(self, key: bytes) -> bool:
        """Whether `gain(key)` would return `current` unchanged (the configuration has not
        switched and no interpolation runs): a caller holding that gain may skip the call."""
        done = self._ticks >= self.transition_ticks
        return self._current is not None and key == self._key and done

    @property
    def current(self) -> np.ndarray | None:
        """The K_h the last `gain` returned (None before the first, or after `clear`)."""
        return self._current

    def clear(self) -> None:
        """Forget every configuration's gain (the cost or the robot changed)."""
        self._gains.clear()
        self._current = self._previous = None
        self._key = b""
