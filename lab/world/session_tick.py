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

from lab.controller.controller import ControlOutput
from lab.controller.hierarchy import HierarchySolution
from lab.controller.hierarchy.solution import SOLVED, SolveStatus
from lab.controller.model import BASE_DOF
from lab.world.native_tick import BEHAVIOUR_RAN, TickStatus
from lab.world.plain_tick import TOUCH_FORCE, PlainTickResults, TickPlan
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
# A fallen robot's joints are damped, as drives in a fall protection's damping mode: b = τ_max /
# this speed, so the drive's full torque brakes a joint turning at it. Undamped, Solo12's 38 g
# shanks spun at up to 900 rad/s (1 ms steps) and MuJoCo's integration diverged
# (docs/architecture.md, "Faults").
LIMP_DAMPING_SPEED = 10.0  # rad/s
# What a failed control raises: the tick falls back to the joint PD (`_fallback_torques`)
CONTROL_FAILURES = (ArithmeticError, np.linalg.LinAlgError, RuntimeError)


class SessionTick(PlainTickResults, SessionBase):
    """A session that ticks (module docstring)."""

    # ----------------------------------------------------------------------------- the tick
    def tick(self) -> None:
        """Advance one control period: read state, control, write torques, one MuJoCo step.
        A state that is not valid before or after the step is a divergence (`_recover`). The
        whole tick is one crossing into C++ (native_tick.py) when the plant, the controller and
        the behaviour allow; else, and when `native_ticks` is False, the Python path below runs
        and `tick_note` says why. Which path runs is decided when what it depends on changes
        (`TickPlan`); a native tick that ends plainly (stepped, status ok) leaves its results in
        the kernel's buffers until they are read (`_settle`)."""
        if self.paused:
            return
        if self.pushes:
            self._expire_pushes()
        plan = self._plan
        if plan is None or not plan.holds(self):
            plan = self._plan = TickPlan(self)
        self.tick_note = plan.note
        if plan.plain:
            # A plain native tick: its crossing (`_plain_crossing`), then its bookkeeping inline
            # (a call costs as much as several of these lines).
            controller, owner = self.controller, plan.owner
            if self.hands.targets:
                self.hands.write(controller.references, self.time)
            stale = owner is not None and owner.native_stale
            if self._plain_crossing(plan, stale):
                if stale and owner is not None:  # its twin ran: it holds the state now
                    owner.native_ran()
                controller.robot.filled_elsewhere()
                self.plant.stepped_elsewhere(plan.server.valid_time, True)
                controller.ticked_elsewhere(plan.outcome)
                self.qp_ok, self._pending = True, plan
                ran = plan.ran
                if ran is self._ran_run:
                    self._ran_run_ticks += 1
                else:
                    self._count_ran(ran)
                self._true_state = plan.truth
                if plan.estimated:  # what the controller read: its model's
                    self.estimator.read_elsewhere(plan.truth, (self.model.q, self.model.v))
                self.ticks += 1
                if self.ticks % FALL_CHECK_PERIOD == 0:
                    self._check_fall(True)
                return
        elif self._pending is not None:  # the last plain tick's results, before this tick's
            self._settle()
        idle = plan.idle
        native = False  # whether the native tick stepped (it made the fall check's contact test)
        try:
            if not plan.note and (stepped := self._control(idle, native=True)) is not None:
                if stepped == TickStatus.DIVERGED_AFTER:
                    self.plant.check()  # raises, naming the cause, as the Python step does
                native = True
                # what the native tick read and applied, through the realism layer if on
                truth = self.native_tick.true_state
                assert truth is not None  # a native tick ran: its buffers exist
                self._true_state = truth
                if self.estimator.native is not None:  # what the controller read: its model's
                    self.estimator.read_elsewhere(truth, (self.model.q, self.model.v))
                self.applied_tau = (
                    self.tau if self.realism.ideal else self.native_tick.applied_torques()
                )
            else:  # the Python tick, or the fallback torques of a failed native control
                if plan.note:
                    self.plant.check()  # a state set from outside (fault injection) first
                    if self.fell:  # torques off until a reset, as a fall protection does; the
                        self.model.update(*self.plant.state())  # model follows (telemetry)
                    else:
                        self._control(idle, native=False)
                self.applied_tau = self.tau if self.fell else self._actuated()
                if self.touch_estimate is not None:  # last tick's torques for the native one
                    self.native_tick.applied_elsewhere(self.applied_tau)
                self.plant.set_torques(self.applied_tau)
                self.plant.step()
        except SimulationDiverged as divergence:
            self._recover(divergence)
            return
        self._ticked(native)

    def warm(self) -> bool:
        """Touch what the next tick runs, changing nothing: the server's loop calls it in its
        spin before a deadline, the caches having gone cold while it slept (docs/performance.md,
        "Where the plain tick goes"). On a plain native tick's plan: the plan's check
        (`TickPlan.holds`) and MuJoCo's forward dynamics on a scratch copy of the plant's state
        (MujocoPlant.warm). Whether there was such a plan to warm."""
        plan = self._plan
        if plan is None or not plan.plain or self.paused:
            return False
        plan.holds(self)
        self.plant.warm()
        return True

    def _plain_crossing(self, plan: TickPlan, stale: bool) -> bool:
        """A plain plan's crossing: whether it stepped with the status ok (its code STEPPED,
        or with BEHAVIOUR_RAN); a control failure it raised, or any other code, is kept in
        `_crossing` for `_control` to handle as every native tick's: events, fallback,
        divergence."""
        controller = self.controller
        controller.ran = plan.ran
        try:
            controller.sync_native_tick()
        except CONTROL_FAILURES as error:
            self._crossing = error
            return False
        # The last plain tick's results, unread, are this tick's to replace: the crossing
        # overwrites the buffers they are in, and every path below sets τ, F and the output.
        self._pending = None
        try:
            code: int = plan.step(self.velocity, stale, None)
        except BaseException as error:
            self.native_tick.crossing_raised(plan.owner)
            if not isinstance(error, CONTROL_FAILURES):
                raise
            self._crossing = error
            return False
        if code == BEHAVIOUR_RAN or code == TickStatus.STEPPED:
            return True
        self._crossing = code
        return False

    def _ticked(self, native: bool) -> None:
        """A tick done: counted, and every FALL_CHECK_PERIOD ticks the fall check (`native`:
        the native tick stepped and made its contact test)."""
        self.ticks += 1
        if self.ticks % FALL_CHECK_PERIOD == 0:
            self._check_fall(native)

    def _check_fall(self, native: bool) -> None:
        """The fall check (`native`: the native tick stepped and made its contact test): a
        fallen robot's torques off, its joints damped, pushes ended, velocity zeroed."""
        if not self.fell and self._fallen(self.native_tick.non_foot_contact if native else None):
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
        if self.hands.targets and not (native and self._crossing is not None):  # written for it
            self.hands.write(controller.references, self.time)
        stepped = None
        with self._capture as caught:
            try:
                if native:
                    stepped, out = self._native_control()
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
            except CONTROL_FAILURES as error:
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

    def _native_control(self) -> tuple[int, ControlOutput]:
        """The native tick's crossing, or the one `_plain_crossing` made (`_crossing`: its
        code or error), with the Python side made current (NativeTick.finish)."""
        crossing, self._crossing = self._crossing, None
        if crossing is None:
            return self.native_tick.run(self.behaviour, self.velocity, self.tau)
        if isinstance(crossing, BaseException):
            raise crossing
        return self.native_tick.finish(crossing, self.behaviour, self.tau)

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
        if self._pending is not None:  # a plain native tick's status is ok
            return SOLVED
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
        self._plan = None  # a push at a point ran the Python tick
        self.plant.clear_push()
        for p in self.pushes.values():
            self.plant.push(p.body, p.force, p.point)
