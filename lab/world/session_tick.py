"""The session's tick (`SessionTick.tick`): read the state through the realism layer, let the
behaviour update the references, solve, write the torques, one MuJoCo step; in one crossing into
C++ when it can (native_tick.py), else in Python, `tick_note` saying why. And what goes wrong in
a tick: a failed solve (fallback torques, rate-limited events), a fall (torques off, joints
damped) and a diverging simulation (the robot standing again at the same sim time):
docs/architecture.md, "Faults".
"""

import math
import time

import numpy as np

from lab.controller.hierarchy import HierarchySolution
from lab.controller.hierarchy.solution import SOLVED, SolveStatus
from lab.controller.model import BASE_DOF
from lab.world.native_tick import TickStatus
from lab.world.plant import SimulationDiverged
from lab.world.session_base import (
    DIVERGENCE_REPEAT_S,
    FAILURE_EVENT_PERIOD,
    STATUS_EVENTS,
    ControllerWarning,
    SessionBase,
)

FALL_HEIGHT_FRACTION = 0.5  # fallen when the base is lower than this fraction of standing height
FALL_TILT = 1.0  # rad: fallen when the base tilts further than this from upright
FALL_CHECK_PERIOD = 10  # ticks between fall checks
# s: a body other than a foot touching the terrain this long is a fall. Shorter is a stumble: a
# blind trot over tiles grazes a shin on a tile edge for a stance phase (≤ 0.35 s) and walks on.
FALL_CONTACT_S = 0.5
TOUCH_FORCE = 1.0  # N: a foot pressing on the ground harder than this touches it
# A fallen robot's joints are damped, as drives in a fall protection's damping mode: b = τ_max /
# this speed, so the drive's full torque brakes a joint turning at it. Undamped, Solo12's 38 g
# shanks spun at up to 900 rad/s (1 ms steps) and MuJoCo's integration diverged
# (docs/architecture.md, "Faults").
LIMP_DAMPING_SPEED = 10.0  # rad/s


class SessionTick(SessionBase):
    """A session that ticks (module docstring)."""

    # ----------------------------------------------------------------------------- the tick
    def tick(self) -> None:
        """Advance one control period: read state, control, write torques, one MuJoCo step.
        A state that is not valid before or after the step is a divergence (`_recover`). The
        whole tick is one crossing into C++ (native_tick.py) when the plant, the controller and
        the behaviour allow; else, and when `native_ticks` is False, the Python path below runs
        and `tick_note` says why."""
        if self.paused:
            return
        if self.pushes:
            self._expire_pushes()
        controller, behaviour, native_tick = self.controller, self.behaviour, self.native_tick
        # An idle behaviour's update changes nothing (Balance off a foot line): the model update
        # and the solve are then one call (one crossing on the native kernel), no touch sensing.
        idle = behaviour.idle and not controller.reads_sensing
        if not self.native_ticks:
            self.tick_note = "native ticks are off (Session.native_ticks)"
        elif not self.fell and self.estimator.filter is not None:  # the Python filter's
            self.tick_note = (
                f"the state estimator ({self.estimator.name}) runs in Python (realism.md)"
            )
        else:
            self.tick_note = native_tick.note(behaviour, idle, self.fell, self.realism)
        native = False  # whether the native tick stepped (it made the fall check's contact test)
        try:
            if not self.tick_note and (stepped := self._control(idle, native=True)) is not None:
                if stepped == TickStatus.DIVERGED_AFTER:
                    self.plant.check()  # raises, naming the cause, as the Python step does
                native = True
                # what the native tick read and applied, through the realism layer if on
                truth = native_tick.true_state
                assert truth is not None  # a native tick ran: its buffers exist
                self._true_state = truth
                if self.estimator.native is not None:  # what the controller read: its model's
                    self.estimator.read_elsewhere(truth, (self.model.q, self.model.v))
                self.applied_tau = self.tau if self.realism.ideal else native_tick.applied_torques()
            else:  # the Python tick, or the fallback torques of a failed native control
                if self.tick_note:
                    self.plant.check()  # a state set from outside (fault injection) first
                    if self.fell:  # torques off until a reset, as a fall protection does; the
                        self.model.update(*self.plant.state())  # model follows (telemetry)
                    else:
                        self._control(idle, native=False)
                self.applied_tau = self.tau if self.fell else self._actuated()
                if self.touch_estimate is not None:  # last tick's torques for the native one
                    native_tick.applied_elsewhere(self.applied_tau)
                self.plant.set_torques(self.applied_tau)
                self.plant.step()
        except SimulationDiverged as divergence:
            self._recover(divergence)
            return
        self.ticks += 1
        if (
            self.ticks % FALL_CHECK_PERIOD == 0
            and not self.fell
            and self._fallen(native_tick.non_foot_contact if native else None)
        ):
            self.fell = True
            self.tau, self.forces = np.zeros_like(self.tau), np.zeros_like(self.forces)
            self.applied_tau = self.tau
            self.plant.set_joint_damping(self.robot.torque_limits / LIMP_DAMPING_SPEED)
            self.pushes.clear()
            self.plant.clear_push()
            self.velocity = np.zeros(3)  # a robot stood up again must not walk off
            self._event(
                "fall",
                "the robot fell: torques off, joints damped, pushes ended and velocity zeroed "
                "until reset",
            )

    # The realism seams (lab/realism, docs/realism.md): the controller reads `_measure`'s
    # state, the plant applies `_actuated`'s torques; the `estimator` knob's EKF sits in `_measure`.
    def _measure(self) -> tuple[np.ndarray, np.ndarray]:
        """The state the controller reads this tick: the true one through the realism layer's
        measurement delay, IMU and encoders (the true one when the layer is ideal), its base
        estimated by the EKF when the `estimator` knob says so (world/estimator.py)."""
        self._true_state = truth = self.plant.state()
        measured = truth if self.realism.ideal else self.realism.measure(*truth)
        contacts = self.controller.references.contact_active  # the controller's (last tick's)
        return self.estimator.read(truth, measured, contacts)

    def _actuated(self) -> np.ndarray:
        """The joint torques the drives apply for the controller's `tau` (N m): the command
        delay and actuator model of the realism layer (`tau` itself when it is ideal)."""
        return self.tau if self.realism.ideal else self.realism.actuate(self.tau, *self._true_state)

    def _control(self, idle: bool, native: bool) -> int | None:
        """This tick's torques and planned contact forces: the controller's, or fallback ones.
        `native`: the whole tick in one crossing (native_tick.py), which also applies the
        torques and steps; returns how it ended when it did, a TickStatus value (None when
        the controller failed: the caller applies the fallback torques, or when not
        `native`). Raises SimulationDiverged when the state was not valid before control."""
        controller, behaviour = self.controller, self.behaviour
        if self.hands.targets:
            self.hands.write(controller.references, self.time)
        stepped = None
        with self._capture as caught:
            try:
                if native:
                    stepped, out = self.native_tick.run(
                        behaviour,
                        idle,
                        self.velocity,
                        self.tau,
                        TOUCH_FORCE,
                        self.realism,
                        self.estimator,
                    )
                else:
                    q, v = self._measure()
                    # sensing, not control (an idle behaviour reads none)
                    touching = None if idle else self.plant.feet_touching(TOUCH_FORCE)
                    start = time.perf_counter()
                    if touching is None:
                        out = controller.compute(q, v)
                    else:
                        controller.update(q, v)
                        if self.touch_estimate is not None:  # realism's, from the torques
                            touching = self.touch_estimate.update(
                                self.model, self.applied_tau, v[BASE_DOF:], touching
                            )
                        if controller.reads_sensing:  # measured only for a task that reads it
                            controller.set_sensing(self.plant.foot_forces(), self.tau)  # Kim 12
                        behaviour.update(self.time, self.model, self.velocity, touching)
                        out = controller.solve()
                if not out.torques_finite():
                    raise FloatingPointError("non-finite torques")
                self.tau, self.forces, self.qp_ok = out.tau, out.forces, True
                self._output = out
                status = out.solve_status()
                if status is not SOLVED:
                    extra = {"levels": list(out.fallback_levels)} if out.fallback_levels else {}
                    self._report(
                        STATUS_EVENTS[status.status],
                        status.reason,
                        self._control_time(native),
                        status=status.status,
                        level=status.level,
                        **extra,
                    )
            except SimulationDiverged:
                raise
            except (ArithmeticError, np.linalg.LinAlgError, RuntimeError) as error:
                if native:  # the native tick did not step: the plant is at this tick's state
                    q, v = self._true_state = self.plant.state()  # _actuated reads it too
                self.tau, self.forces = self._fallback_torques(q, v), 0 * self.forces
                self.qp_ok, self._output = False, None
                self.qp_failures += 1
                self._failure = f"{type(error).__name__}: {error}; fallback torques"
                self._report(
                    "solver_failure",
                    self._failure,
                    self._control_time(native),
                    status="failed",
                    level=None,
                )
        self._count_ran(controller.ran)
        self.control_us = (
            self.native_tick.control_us if native else (time.perf_counter() - start) * 1e6
        )
        for caught_warning in caught:
            kind = caught_warning.category.__name__
            count = self._warnings[kind].ticks + 1 if kind in self._warnings else 1
            message, t = str(caught_warning.message), self._control_time(native)
            self._warnings[kind] = ControllerWarning(message, t, count)
        return stepped

    def _control_time(self, native: bool) -> float:
        """The sim time this tick controlled at: the native tick has stepped already."""
        return self.native_tick.tick_time if native else self.time

    def tick_report(self) -> dict:
        """Which path ran the last tick: `native` (one crossing) or `python`, and why."""
        return {"tick": "python" if self.tick_note else "native", "tick_note": self.tick_note}

    @property
    def status(self) -> SolveStatus:
        """The last tick's status: `failed` (fallback torques) with the error, or how the
        hierarchy found x (ok before the first tick)."""
        if not self.qp_ok:
            return SolveStatus("failed", None, self._failure)
        return SOLVED if self._output is None else self._output.solve_status()

    @property
    def solution(self) -> HierarchySolution | None:
        """The last tick's hierarchy solution (built when read), None after a fallback."""
        return None if self._output is None else self._output.solution

    def _recover(self, divergence: SimulationDiverged) -> None:
        """After a divergence: the robot standing again at the same sim time (the clock never runs
        backwards); a second divergence within DIVERGENCE_REPEAT_S also pauses until `reset`."""
        repeated = divergence.time - self._last_divergence < DIVERGENCE_REPEAT_S
        self._reset_state(time=divergence.time)
        self._last_divergence = divergence.time
        self.divergences += 1
        self.paused = repeated
        then = (
            f"again within {DIVERGENCE_REPEAT_S:g} s: paused until reset"
            if repeated
            else "robot reset to standing"
        )
        self._event(
            "sim_diverged",
            f"the simulation diverged ({divergence.cause}); {then}",
            cause=divergence.cause,
            restored="paused" if repeated else "standing",
        )

    def _report(self, kind: str, message: str, at: float, **extra: object) -> None:
        """One event of `kind` (a value of STATUS_EVENTS) per FAILURE_EVENT_PERIOD at most, with
        the count of ticks since the last one; `at`: the sim time of the tick it concerns."""
        self._unreported[kind] += 1
        if at - self._last_report[kind] >= FAILURE_EVENT_PERIOD:
            self._event(kind, message, at, count=self._unreported[kind], **extra)
            self._unreported[kind] = 0
            self._last_report[kind] = at

    def _fallback_torques(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Joint PD to the reference posture plus the bias forces: safe for one or a few ticks."""
        gains = self.controller.posture_gains()
        refs = self.controller.references
        bias = self.model.h[BASE_DOF:] if np.all(np.isfinite(self.model.h)) else 0.0
        tau = bias + gains.kp * (refs.posture - q[7:]) - gains.kd * v[BASE_DOF:]
        tau = np.nan_to_num(tau)
        return np.clip(tau, -self.robot.torque_limits, self.robot.torque_limits)

    def _fallen(self, non_foot_contact: bool | None = None) -> bool:
        """Whether the robot fell: too low, too tilted, or a body other than a foot on the
        terrain too long; `non_foot_contact`: that test's answer when the native tick made it
        (None: ask the plant)."""
        # the lab judges the true state (pinocchio conventions: quaternion x, y, z, w); with the
        # realism layer ideal, the model's state is it
        exact = self.realism.ideal and not self.estimator.active
        q = self.model.q if exact else self._true_state[0]
        height = q[2]
        upright = 1.0 - 2.0 * (q[3] ** 2 + q[4] ** 2)  # z of the base z axis, from the quaternion
        tilt = math.acos(min(1.0, max(-1.0, float(upright))))
        if non_foot_contact is None:
            non_foot_contact = self.plant.non_foot_ground_contact()
        if not non_foot_contact:
            self._non_foot_contact_since = None
        elif self._non_foot_contact_since is None:
            self._non_foot_contact_since = self.time
        return (
            height < FALL_HEIGHT_FRACTION * self.robot.q_standing[2]
            or tilt > FALL_TILT
            or (
                self._non_foot_contact_since is not None
                and self.time - self._non_foot_contact_since >= FALL_CONTACT_S
            )
        )

    def _expire_pushes(self) -> None:
        expired = [name for name, p in self.pushes.items() if self.time >= p.ends_at]
        if not expired:
            return
        for name in expired:
            del self.pushes[name]
        self.plant.clear_push()
        for p in self.pushes.values():
            self.plant.push(p.body, p.force, p.point)
