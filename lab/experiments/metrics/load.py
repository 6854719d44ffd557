"""Metrics of the Hutter 2014 §5.1 experiments, fed once per tick (see metrics.py).

- `load_distribution`: E_τ = ∫ τᵀτ dt (eq. 60) of the commanded torques; μ̄ (eq. 61), the mean
  over ticks and loaded support feet of |F_tangential| / F_normal about the local surface normal,
  for the controller's forces and for the ones MuJoCo measures; the largest |τ| of the knee
  (KFE) and hip (HFE) joints; the largest excess of any |τ| over its torque limit.
- `torque_steps`: the largest one-tick change of any joint torque within SWITCH_WINDOW after a
  foot is added to or removed from the support set (§5.1.6), and the largest anywhere.
- `foot_slip`: how far support feet slide (horizontally) from where they were when the support
  phase began: the largest, and the mean over support phases.
- `body_tracking`: body-height and pitch errors against the references (largest, and RMS over the
  last second), and the largest HFE angle reached (Sim5, Exp6/7).
"""

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from lab.controller.references import surface_normals

if TYPE_CHECKING:
    from lab.world.session import Session

LOADED = 5.0  # N: a foot with less normal force does not count in μ̄
SWITCH_WINDOW = 0.005  # s after a contact switch in which torque steps are attributed to it
TAIL = 1.0  # s at the end of the run over which RMS errors are taken


def _joints(session: "Session", suffix: str) -> np.ndarray:
    names = session.model.joint_names
    return np.array([i for i, name in enumerate(names) if name.endswith(suffix)], dtype=int)


def _friction_ratios(forces: np.ndarray, normals: np.ndarray) -> list[float]:
    ratios = []
    for force, normal in zip(forces, normals, strict=True):
        fn = force @ normal
        if fn > LOADED:
            ratios.append(float(np.linalg.norm(force - fn * normal) / fn))
    return ratios


class LoadDistributionMetrics:
    def __init__(self, session: "Session") -> None:
        self.energy = 0.0
        self.commanded: list[float] = []
        self.measured: list[float] = []
        self.knee, self.hip = _joints(session, "KFE"), _joints(session, "HFE")
        self.max_knee = self.max_hip = 0.0
        self.excess = -np.inf

    def update(self, session: "Session") -> None:
        tau, model = session.tau, session.model
        refs = session.controller.references
        dt = session.config.timestep
        self.energy += float(tau @ tau) * dt
        normals = surface_normals(refs, len(model.contacts))
        active = refs.contact_active
        commanded = model.contact_forces_world(session.forces)
        self.commanded += _friction_ratios(commanded[active], normals[active])
        self.measured += _friction_ratios(session.plant.foot_forces()[active], normals[active])
        self.max_knee = max(self.max_knee, float(np.max(np.abs(tau[self.knee]), initial=0.0)))
        self.max_hip = max(self.max_hip, float(np.max(np.abs(tau[self.hip]), initial=0.0)))
        limits = session.controller.torque_limits()
        self.excess = max(self.excess, float(np.max(np.abs(tau) - limits)))

    def result(self) -> dict[str, float]:
        return {
            "energy_tau_n2m2s": self.energy,
            "mean_friction_ratio": float(np.mean(self.commanded)) if self.commanded else 0.0,
            "mean_friction_ratio_measured": float(np.mean(self.measured)) if self.measured else 0.0,
            "max_knee_torque_nm": self.max_knee,
            "max_hip_torque_nm": self.max_hip,
            "max_torque_over_limit_nm": self.excess,
        }


class TorqueStepMetrics:
    def __init__(self, session: "Session") -> None:
        self.previous_tau: np.ndarray | None = None
        self.previous_active = session.controller.references.contact_active.copy()
        self.last_switch = -np.inf
        self.at_switch = self.anywhere = 0.0

    def update(self, session: "Session") -> None:
        active = session.controller.references.contact_active
        if not np.array_equal(active, self.previous_active):
            self.last_switch = session.time
            self.previous_active = active.copy()
        if self.previous_tau is not None and session.qp_ok:
            step = float(np.max(np.abs(session.tau - self.previous_tau)))
            self.anywhere = max(self.anywhere, step)
            if session.time - self.last_switch <= SWITCH_WINDOW + 1e-9:
                self.at_switch = max(self.at_switch, step)
        self.previous_tau = session.tau.copy()

    def result(self) -> dict[str, float]:
        return {
            "max_torque_step_at_switch_nm": self.at_switch,
            "max_torque_step_nm": self.anywhere,
        }


class FootSlipMetrics:
    def __init__(self, session: "Session") -> None:
        n = len(session.model.contacts)
        self.anchor = np.full((n, 2), np.nan)
        self.phase_slip = np.zeros(n)
        self.finished: list[float] = []

    def update(self, session: "Session") -> None:
        active = session.controller.references.contact_active
        positions = session.model.contact_positions[:, :2]
        for i, on in enumerate(active):
            if on and np.isnan(self.anchor[i, 0]):
                self.anchor[i], self.phase_slip[i] = positions[i], 0.0
            elif on:
                slip = float(np.linalg.norm(positions[i] - self.anchor[i]))
                self.phase_slip[i] = max(self.phase_slip[i], slip)
            elif not np.isnan(self.anchor[i, 0]):
                self.finished.append(self.phase_slip[i])
                self.anchor[i] = np.nan

    def result(self) -> dict[str, float]:
        phases = self.finished + [
            s for s, a in zip(self.phase_slip, self.anchor[:, 0], strict=True) if not np.isnan(a)
        ]
        return {
            "max_foot_slip_m": float(max(phases, default=0.0)),
            "mean_foot_slip_m": float(np.mean(phases)) if phases else 0.0,
        }


class BodyTrackingMetrics:
    def __init__(self, session: "Session") -> None:
        self.hfe = _joints(session, "HFE")
        self.samples: list[tuple[float, float, float]] = []
        self.max_hfe = self.limit_excess = -np.inf

    def update(self, session: "Session") -> None:
        refs, model = session.controller.references, session.model
        height = float(refs.base_height - model.base_position[2])
        pitch = float(pin.rpy.matrixToRpy(refs.base_rotation.T @ model.base_rotation)[1])
        self.samples.append((session.time, height, pitch))
        q = model.joint_positions
        self.max_hfe = max(self.max_hfe, float(np.max(np.abs(q[self.hfe]))))
        lower, upper = session.controller.joint_limits()
        self.limit_excess = max(self.limit_excess, float(np.max(np.maximum(q - upper, lower - q))))

    def result(self) -> dict[str, float]:
        t, height, pitch = (np.array(column) for column in zip(*self.samples, strict=True))
        tail = t >= t[-1] - TAIL
        return {
            "max_height_error_m": float(np.max(np.abs(height))),
            "rms_height_error_last_s_m": float(np.sqrt(np.mean(height[tail] ** 2))),
            "max_pitch_error_rad": float(np.max(np.abs(pitch))),
            "rms_pitch_error_last_s_rad": float(np.sqrt(np.mean(pitch[tail] ** 2))),
            "max_abs_hfe_rad": self.max_hfe,
            "max_joint_limit_excess_rad": self.limit_excess,
        }


LOAD_METRICS = {
    "load_distribution": LoadDistributionMetrics,
    "torque_steps": TorqueStepMetrics,
    "foot_slip": FootSlipMetrics,
    "body_tracking": BodyTrackingMetrics,
}
