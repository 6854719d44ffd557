"""What a session publishes: the `lab/telemetry` and `lab/state` messages (docs/protocol.md).

Plain reads of a running session, JSON-ready: nothing here changes the session. The session
module calls these; this module does not import it (it reads a `SessionView`).
"""

from collections.abc import Callable, Mapping
from typing import Protocol

import numpy as np

from lab.controller.behaviours.base import Behaviour
from lab.controller.hierarchy import HierarchySolution
from lab.controller.hierarchy.solution import SolveStatus
from lab.controller.model import RobotModel
from lab.controller.native import NativeController
from lab.protocol import TaskGains
from lab.realism.layer import NativeRealismLayer, RealismLayer
from lab.robot import FramePlacements, Robot
from lab.world.estimator import BaseEstimator
from lab.world.plant import MujocoPlant

COP_MIN_FORCE = 1e-6  # N: a foot or the robot pressing less than this has no centre of pressure
PREDICTION_STRIDE = 2  # of the planner's 10 ms rows: 20 ms apart in telemetry


class PushView(Protocol):
    """An external force in progress (the session's `Push`)."""

    body: str
    force: np.ndarray
    point: np.ndarray | None
    ends_at: float


class ConfigView(Protocol):
    robot: str
    scene: str


class SessionView(Protocol):
    """The parts of a `Session` the messages read (read-only: a message changes nothing)."""

    @property
    def config(self) -> ConfigView: ...

    @property
    def realism(self) -> RealismLayer | NativeRealismLayer: ...

    robot: Robot
    frame_placements: FramePlacements
    plant: MujocoPlant
    model: RobotModel
    estimator: BaseEstimator
    controller: NativeController
    behaviour: Behaviour
    paused: bool
    fell: bool
    divergences: int
    qp_ok: bool
    qp_failures: int
    control_us: float

    @property
    def solution(self) -> HierarchySolution | None: ...

    @property
    def status(self) -> SolveStatus: ...

    def recent_warnings(self) -> list[dict]: ...

    def tick_report(self) -> dict: ...

    forces: np.ndarray
    velocity: np.ndarray

    @property
    def pushes(self) -> Mapping[str, PushView]: ...

    @property
    def time(self) -> float: ...


def hierarchy_report(controller: NativeController) -> dict:
    """The hierarchy in use: method, QP solver, nullspace formulation."""
    config = controller.config
    return {"method": config.method, "solver": config.solver, "formulation": config.formulation}


def internal_force_report(controller: NativeController) -> dict:
    """The internal force between the point feet in support (Kim 2016 §IV, N, > 0 pushing
    apart): reference, K_F, sensed source and, at the last tick (empty lists with fewer than
    two point feet in support or the task out of the stack), the sensed value and the command
    of eq. 12."""
    task = controller.internal_force
    running = task.name in controller.config.stack.names()
    return {
        "reference": task.reference,
        "gain": task.gains.kp,
        "source": task.source,
        "sensed": task.sensed.tolist() if running else [],
        "command": task.command.tolist() if running else [],
    }


def stepping_report(behaviour: Behaviour, model: RobotModel) -> dict | None:
    """A point-foot stepping behaviour's state for the phase portraits (Kim 2016 Figs. 4–5):
    touchdowns, swings cut short, the CoM and its velocity in the heading frame (the base's
    yaw, world origin; m, m/s: forward, lateral), and the planner's last prediction (its
    footstep and the CoM's predicted [t, x, ẋ] rows per axis, every 20 ms); None for other
    behaviours."""
    stepping = behaviour.stepping
    if stepping is None:
        return None
    prediction = stepping.prediction
    yaw = float(np.arctan2(model.base_rotation[1, 0], model.base_rotation[0, 0]))
    c, s = np.cos(yaw), np.sin(yaw)
    to_heading = np.array([[c, s], [-s, c]])
    report = {
        "steps": stepping.steps,
        "swings_cut": stepping.shortened,
        "com": (to_heading @ model.com[:2]).tolist(),
        "com_velocity": (to_heading @ model.com_velocity[:2]).tolist(),
        "prediction": None,
    }
    if prediction is not None:
        report["prediction"] = {
            "t": prediction.t,
            "foot": prediction.foot.tolist(),
            "forward": prediction.forward[::PREDICTION_STRIDE].tolist(),
            "lateral": prediction.lateral[::PREDICTION_STRIDE].tolist(),
        }
    return report


def momentum_report(controller: NativeController) -> dict:
    """The momentum task's feedback law (Herzog 2016 §3) and which LQR gain is in use (its
    contact configuration, blending in, designed off the loop and not arrived yet, how many were
    designed; None under `pd` or without the task)."""
    return {"mode": controller.momentum_mode(), "gain_in_use": controller.momentum_gain_in_use()}


def momentum_gain_report(controller: NativeController) -> list[list[float]] | None:
    """The momentum task's K_h at the current contact configuration, rows ḣ (linear, angular),
    columns [Δc; Δh_lin; Δh_ang], to 4 significant digits; None while the task is not in the
    stack. For `info` and the `momentum` reply, not telemetry (an LQR design is a Riccati solve
    the first time a configuration is seen)."""
    gain = controller.momentum_gain()
    return None if gain is None else [[float(f"{k:.4g}") for k in row] for row in gain]


def gain_fields(gains: TaskGains, used: tuple[str, ...]) -> dict[str, float | None]:
    """kp, kd and weight of a task, None for those it does not read."""
    given = {"kp": gains.kp, "kd": gains.kd, "weight": gains.weight}
    return {key: value if key in used else None for key, value in given.items()}


def task_gains_report(controller: NativeController) -> list[dict]:
    """Every task's gains and weight (the `info` reply's `tasks`); a gain the task does not read
    is None (the UI hides it) and `gains` lists those it reads."""
    used = controller.gains_used()
    return [
        {"name": name, **gain_fields(g, used[name]), "gains": list(used[name])}
        for name, g in controller.gains().items()
    ]


def foot_centre_of_pressure(
    wrench: np.ndarray, position: np.ndarray, rotation: np.ndarray
) -> list[float] | None:
    """CoP (world) of a flat foot's contact wrench [f, m] in the sole frame (origin `position`,
    axes `rotation`, world); None when the foot is unloaded."""
    _, _, fz, mx, my, _ = wrench.tolist()  # Python floats: cheaper than numpy scalars
    if fz <= COP_MIN_FORCE:
        return None
    cop_local = np.array([-my / fz, mx / fz, 0.0])
    return (position + rotation @ cop_local).tolist()


def net_centre_of_pressure(normal: np.ndarray, positions: np.ndarray) -> list[float] | None:
    """CoP of the feet's normal forces `normal` (N) at `positions` (world), on the ground plane
    z = 0; None in flight."""
    total = normal.sum()
    if total <= COP_MIN_FORCE:
        return None
    cop = (normal @ positions / total).tolist()
    cop[2] = 0.0
    return cop


def _contacts(session: SessionView) -> tuple[list[dict], dict]:
    """One entry per foot and the centres of pressure (`cop`) of the telemetry message. The
    arrays become lists once each (one tolist per array, not per foot: the message is built on
    a tick of the 1 kHz loop)."""
    model = session.model
    measured = session.plant.foot_forces()
    positions = model.contact_positions
    commanded = model.contact_forces_world(session.forces).tolist()
    active = session.controller.references.contact_active
    contacts = []
    feet_cop: dict[str, list[float] | None] = {}
    for i, (contact, rows, position, measured_force) in enumerate(
        zip(model.contacts, model.force_slices, positions.tolist(), measured.tolist(), strict=True)
    ):
        entry = {
            "name": contact.name,
            "kind": contact.kind,
            "active": bool(active[i]),
            "position": position,
            "measured_force": measured_force,
            "force": commanded[i],
        }
        if contact.kind == "flat":
            wrench = session.forces[rows]
            R = model.contact_rotations[i]
            entry["moment"] = (R @ wrench[3:]).tolist()
            feet_cop[contact.name] = foot_centre_of_pressure(wrench, positions[i], R)
        contacts.append(entry)
    net = net_centre_of_pressure(measured[:, 2], positions)
    return contacts, {"feet": feet_cop, "net": net}


def _tasks(controller: NativeController, errors: dict[str, float]) -> list[dict]:
    """The stack's tasks, level by level, with their gains and `errors` (by name)."""
    tasks = controller.tasks
    entries = []
    for level, names in enumerate(controller.config.stack.levels):
        for name in names:
            task = tasks.get(name)
            gains = (
                {"kp": None, "kd": None, "weight": 1.0}
                if task is None
                else gain_fields(task.gains, task.GAINS)
            )
            entries.append({"name": name, "level": level, "error": errors.get(name, 0.0), **gains})
    return entries


def telemetry_message(session: SessionView) -> dict:
    """Everything the UI plots and the tests check, JSON-ready (`lab/telemetry`)."""
    message, finish = telemetry_in_two(session)
    finish()
    return message


def telemetry_in_two(session: SessionView) -> tuple[dict, Callable[[], None]]:
    """The telemetry message in two steps, for two ticks of the realtime loop (one costs up to
    ~0.3 ms in the server, its caches cold: docs/performance.md, "Why the loop is built this way"):
    the message of this tick with None for the parts that read no state the next tick overwrites,
    and `finish`, which fills them in later: the stack's tasks with this tick's errors, this tick's
    solution summary, and the controller's configuration (stack, method, momentum mode, kernel
    note; as of `finish` when a command changed them in between). `ran` (kernel, method, solver,
    formulation, the kernel that ran the behaviour's update — native, python or none — and the
    note saying why they differ from the request; the tick's path, native or python, and why
    python) and `status` are this tick's."""
    model, controller = session.model, session.controller
    q = model.q[:7].tolist()
    rotation = model.base_rotation
    contacts, cop = _contacts(session)
    momentum = model.centroidal_momentum().tolist()
    solution, errors = session.solution, controller.task_errors()
    status, ran = session.status, controller.ran
    message = {
        "t": session.time,
        "robot": session.config.robot,
        "scene": session.config.scene,
        "paused": session.paused,
        "fell": session.fell,
        "divergences": session.divergences,
        "gait": session.behaviour.name,
        "base": {
            "position": q[:3],
            "quaternion": q[3:],
            "linear_velocity": (rotation @ model.v[:3]).tolist(),
            "angular_velocity": (rotation @ model.v[3:6]).tolist(),
        },
        "com": {"position": model.com.tolist(), "velocity": model.com_velocity.tolist()},
        "momentum": {"linear": momentum[:3], "angular": momentum[3:]},
        "contacts": contacts,
        "cop": cop,
        "tasks": None,
        "stack": None,
        "momentum_control": None,
        "internal_force": internal_force_report(controller),
        "stepping": stepping_report(session.behaviour, model),
        "hierarchy": None,
        "kernel": controller.kernel_ran,
        "kernel_note": None,
        "ran": {
            **ran.report(),
            "behaviour": session.behaviour.kernel_ran,
            "note": controller.note,
            **session.tick_report(),
            "estimator": session.estimator.name,
        },
        # which realism ran (lab/realism; every knob is in `info`), the payloads fixed (kg)
        "realism": {
            "preset": session.realism.knobs.preset,
            "ideal": session.realism.ideal,
            "kernel": session.realism.kernel,
            "payloads": dict(session.plant.payloads),
        },
        # what the controller read of the base against the truth (lab/world/estimator.py); the
        # native tick reads the true state itself
        "estimator": session.estimator.report(
            exact=session.tick_report()["tick"] == "native" and not session.estimator.active
        ),
        "status": status.report(),
        "controller_warnings": session.recent_warnings(),
        "qp": {
            "solve_us": session.control_us,
            "failures": session.qp_failures,
        },
        "solution": None,
        "command": dict(zip(("vx", "vy", "yaw_rate"), session.velocity.tolist(), strict=True)),
        "pushes": [
            {
                "body": p.body,
                "force": p.force.tolist(),
                "point": (
                    p.point if p.point is not None else model.frame_position(p.body)
                ).tolist(),
                "remaining": max(0.0, p.ends_at - session.time),
            }
            for p in session.pushes.values()
        ],
    }

    def finish() -> None:
        message["tasks"] = _tasks(controller, errors)
        message["stack"] = controller.config.stack.as_lists()
        message["momentum_control"] = momentum_report(controller)
        message["hierarchy"] = hierarchy_report(controller)
        message["kernel_note"] = controller.kernel_note
        message["solution"] = None if solution is None else solution.summary()

    return message, finish


def state_message(session: SessionView) -> dict:
    """What the UI needs to draw the robot (`lab/state`): base pose, joint positions and the
    world placement of every link and contact frame; in a scene whose terrain moves, the pose of
    each moving body (`scene_bodies`)."""
    q, _ = session.plant.state()
    message = {
        "t": session.time,
        "robot": session.config.robot,
        "base": {"position": q[:3].tolist(), "quaternion": q[3:7].tolist()},
        "joints": {"names": list(session.robot.joint_names), "positions": q[7:].tolist()},
        "frames": session.frame_placements.message(q),
    }
    if session.plant.moving_terrain.body_ids:
        message["scene_bodies"] = session.plant.scene_body_poses()
    return message
