"""The session: commands between ticks, pushes, fallbacks, falls, telemetry."""

import dataclasses
import gc
import json
import math
import warnings
import weakref

import numpy as np
import pinocchio as pin
import pytest

from lab.controller import hierarchy
from lab.controller.hierarchy.nullspace import ActiveSetCapWarning
from lab.controller.qp import QPFailure
from lab.protocol import RobotCommand
from lab.world.session import WARNING_HOLD_S, Session, SessionConfig
from lab.world.session_parts import build_parts
from lab.world.session_tick import FALL_CONTACT_S, LIMP_DAMPING_SPEED


@pytest.fixture(scope="module")
def session() -> Session:
    return Session(SessionConfig(robot="anymal"))


def run(session: Session, seconds: float) -> None:
    for _ in range(round(seconds / session.config.timestep)):
        session.tick()


def test_a_push_moves_the_base_in_the_pushed_direction_and_it_recovers() -> None:
    session = Session(SessionConfig(robot="anymal"))
    run(session, 0.2)
    y0 = session.telemetry()["base"]["position"][1]
    reply = session.handle("push", {"body": "base", "force": [0.0, 150.0, 0.0], "duration": 0.1})
    assert reply["ok"], reply
    run(session, 0.1)
    pushed = session.telemetry()
    assert pushed["base"]["linear_velocity"][1] > 0.05  # m/s, along +y as pushed
    assert pushed["pushes"][0]["body"] == "base"
    run(session, 1.5)
    after = session.telemetry()
    assert not after["fell"] and after["pushes"] == []
    assert abs(after["base"]["linear_velocity"][1]) < 0.02
    assert abs(after["com"]["position"][1] - y0) < 0.01  # the CoM task brings it back


def test_a_humanoid_stands_a_short_hard_push() -> None:
    """150 N for 0.1 s on Talos's base: with undamped sole velocities a sole that began to tip
    kept turning, the feet bounced and Talos fell (the contact task's kd, robots/talos.toml)."""
    session = Session(SessionConfig(robot="talos"))
    run(session, 1.0)
    session.handle("push", {"body": "base_link", "force": [0.0, 150.0, 0.0], "duration": 0.1})
    run(session, 2.0)
    assert not session.fell and session.qp_failures == 0
    assert abs(session.telemetry()["base"]["linear_velocity"][1]) < 0.05  # m/s: recovered


@pytest.mark.parametrize(
    ("verb", "payload", "needle"),
    [
        ("stack", {"levels": [["contact"], ["no_such_task"]]}, "no_such_task"),
        ("stack", {"levels": [["contact", "contact"]]}, "contact"),
        ("gains", {"task": "com", "kp": -1.0}, "kp"),
        ("gains", {"task": "nope", "kp": 1.0}, "nope"),
        ("gains", {"task": "com", "kp": math.nan}, "kp"),
        ("hierarchy", {"method": "magic"}, "magic"),
        ("hierarchy", {"method": "cascade", "solver": "osqp"}, "osqp"),
        ("robot", {"name": "atlas"}, "atlas"),
        ("scene", {"name": "moon"}, "moon"),
        ("push", {"body": "no_link", "force": [1.0, 0.0, 0.0], "duration": 0.1}, "no_link"),
        ("push", {"body": "base", "force": [1.0, 0.0], "duration": 0.1}, "force"),
        ("velocity", {"vx": math.inf}, "vx"),
        ("teleport", {}, "teleport"),
        ("gait", {"name": "moonwalk"}, "moonwalk"),
    ],
)
def test_bad_commands_are_rejected_by_name_and_change_nothing(
    session: Session, verb: str, payload: dict, needle: str
) -> None:
    before = json.dumps(session.info(), sort_keys=True)
    reply = session.handle(verb, payload)
    assert reply["ok"] is False
    assert needle in reply["error"]
    assert json.dumps(session.info(), sort_keys=True) == before
    session.tick()  # and the loop goes on


def test_stack_gains_and_hierarchy_changes_show_in_telemetry(session: Session) -> None:
    levels = [["friction", "torque_limits"], ["contact"], ["base_orientation", "com"], ["posture"]]
    assert session.handle("stack", {"levels": levels})["ok"]
    assert session.handle("gains", {"task": "com", "kp": 50.0})["ok"]
    assert session.handle("hierarchy", {"method": "weighted", "solver": "clarabel"})["ok"]
    session.tick()
    telemetry = session.telemetry()
    assert telemetry["stack"] == levels
    assert telemetry["hierarchy"] == {
        "method": "weighted",
        "solver": "clarabel",
        "formulation": "qdd_force",
    }
    assert next(t for t in telemetry["tasks"] if t["name"] == "com")["kp"] == 50.0
    assert telemetry["status"] == {"status": "ok", "level": None, "reason": ""}
    # Clarabel is asked: the Python kernel runs it, and telemetry says so
    assert telemetry["ran"]["kernel"] == "python" and telemetry["ran"]["solver"] == "clarabel"


@pytest.mark.parametrize("kernel", ["native", "python"])
def test_telemetry_built_over_two_ticks_is_the_first_ticks_message(kernel: str) -> None:
    """The loop builds telemetry in two steps on two ticks: what `finish` adds later (the
    tasks' errors, the solution summary) is the first tick's, as one call there gives."""
    session = Session(SessionConfig(robot="anymal"))
    assert session.handle("hierarchy", {"kernel": kernel})["ok"]
    assert session.handle("push", {"body": "base", "force": [40.0, 0.0, 0.0], "duration": 0.2})[
        "ok"
    ]
    run(session, 0.05)
    whole = json.dumps(session.telemetry())
    message, finish = session.telemetry_in_two()
    assert message["tasks"] is None and message["solution"] is None  # filled in by finish
    session.tick()
    finish()
    assert json.dumps(message) == whole
    assert message["solution"] is not None and any(t["error"] > 0.0 for t in message["tasks"])


def test_the_nullspace_formulation_shows_and_survives_a_scene_switch() -> None:
    session = Session(SessionConfig(robot="anymal"))
    reply = session.handle("hierarchy", {"method": "nullspace", "formulation": "sequential"})
    assert reply["hierarchy"]["formulation"] == "sequential"
    assert session.handle("scene", {"name": "rough"})["ok"]
    run(session, 0.05)
    hierarchy_now = session.telemetry()["hierarchy"]
    assert hierarchy_now == {"method": "nullspace", "solver": "daqp", "formulation": "sequential"}
    assert session.controller.config.formulation == "sequential"
    assert "sequential" in session.info()["formulations"]


def test_a_solver_failure_falls_back_counts_and_carries_on(monkeypatch) -> None:
    session = Session(
        SessionConfig(robot="anymal", kernel="python")
    )  # the failure is injected there
    run(session, 0.1)

    def failing(problem, solver):
        raise QPFailure("injected failure")

    monkeypatch.setitem(hierarchy.METHODS, "cascade", failing)
    run(session, 0.02)
    assert session.qp_failures == 20
    assert any(e["type"] == "solver_failure" for e in session.pop_events())
    monkeypatch.undo()
    run(session, 0.5)
    assert session.qp_failures == 20
    assert not session.fell
    assert abs(session.telemetry()["base"]["position"][2] - session.robot.q_standing[2]) < 0.02
    assert session.handle("reset")["ok"]  # counted since the session started (the soak's
    assert session.telemetry()["qp"]["failures"] == 20  # report read 0 after resets)


def test_a_level_that_fell_back_is_in_telemetry_and_an_event(monkeypatch) -> None:
    """The cascade's `kept_above` level is visible: telemetry's `solution` and one
    solver_fallback event per 0.5 s; the torques are the hierarchy's, not fallback torques."""
    session = Session(SessionConfig(robot="anymal", kernel="python"))
    run(session, 0.05)
    solution = session.telemetry()["solution"]
    assert session.telemetry()["status"]["status"] == "ok" and solution["fallback_levels"] == []
    assert len(solution["levels"]) == len(session.controller.config.stack.levels)
    solve = hierarchy.METHODS["cascade"]

    def second_level_fails(problem, solver):
        found = solve(problem, solver)
        levels = list(found.levels)
        levels[1] = "kept_above"
        return dataclasses.replace(found, levels=tuple(levels))

    monkeypatch.setitem(hierarchy.METHODS, "cascade", second_level_fails)
    session.pop_events()
    run(session, 0.02)
    telemetry = session.telemetry()
    assert telemetry["status"]["status"] == "fallback" and telemetry["status"]["level"] == 1
    assert "level 1 failed" in telemetry["status"]["reason"]
    assert telemetry["solution"]["fallback_levels"] == [1]
    assert session.qp_failures == 0  # one status: fallback, not a failed tick
    events = [e for e in session.pop_events() if e["type"] == "solver_fallback"]
    assert len(events) == 1 and events[0]["levels"] == [1]
    assert (events[0]["status"], events[0]["level"]) == ("fallback", 1)


def test_a_shape_bug_fails_loudly(monkeypatch) -> None:
    """A ValueError inside the tick is a bug, not a solver failure: it propagates."""
    session = Session(SessionConfig(robot="anymal", kernel="python"))

    def shape_bug(problem, solver):
        raise ValueError("operands could not be broadcast together")

    monkeypatch.setitem(hierarchy.METHODS, "cascade", shape_bug)
    with pytest.raises(ValueError, match="broadcast"):
        session.tick()


def test_a_controller_warning_shows_in_telemetry_while_it_lasts(monkeypatch) -> None:
    """nullspace's active-set cap (or any warning the controller raises) is in telemetry, for
    the status line, until WARNING_HOLD_S of sim time after the last tick that raised it."""
    session = Session(SessionConfig(robot="anymal", kernel="python"))
    cascade = hierarchy.METHODS["cascade"]

    def capped(problem, solver):
        warnings.warn("active set stopped at the cap", ActiveSetCapWarning, stacklevel=1)
        return cascade(problem, solver)

    monkeypatch.setitem(hierarchy.METHODS, "cascade", capped)
    run(session, 0.02)
    (warning,) = session.telemetry()["controller_warnings"]
    assert warning["kind"] == "ActiveSetCapWarning" and warning["ticks"] == 20
    assert warning["message"] == "active set stopped at the cap"
    assert session.qp_ok  # a warning is not a failure: the controller's torques were applied
    monkeypatch.undo()
    run(session, WARNING_HOLD_S / 2)
    assert len(session.telemetry()["controller_warnings"]) == 1
    run(session, WARNING_HOLD_S)
    assert session.telemetry()["controller_warnings"] == []


def test_a_robot_switch_and_a_reset(session: Session) -> None:
    assert session.handle("robot", {"name": "solo12"})["ok"]
    assert session.telemetry()["robot"] == "solo12"
    assert len(session.telemetry()["contacts"]) == 4
    run(session, 0.05)
    assert session.handle("reset")["ok"]
    assert session.time == 0.0
    assert session.handle("robot", {"name": "anymal"})["ok"]


def _ticked(session: Session, ticks: int) -> list[np.ndarray]:
    """Each tick's q, v and torques over `ticks` ticks."""
    states = []
    for _ in range(ticks):
        session.tick()
        states.extend((*session.plant.state(), session.tau.copy()))
    return states


def test_a_robot_swapped_in_ticks_as_a_new_session_of_it() -> None:
    """A switch's parts stand before the swap (`build_parts` resets them on the switch's
    thread, each hand held where it stands): swapped into a session that ran another robot for
    0.03 s, B1-Z1 (its arm's hand held) ticks bit for bit as a session started with it, and
    after a reset again."""
    session = Session(SessionConfig(robot="solo12"))
    run(session, 0.03)
    session.install(build_parts(session.switch_config(RobotCommand("b1_z1"))))
    fresh = Session(SessionConfig(robot="b1_z1"))
    assert session.hands.report() == fresh.hands.report() and session.hands.names
    assert all(
        np.array_equal(a, b) for a, b in zip(_ticked(session, 20), _ticked(fresh, 20), strict=True)
    )
    assert session.handle("reset")["ok"] and fresh.handle("reset")["ok"]
    assert all(
        np.array_equal(a, b) for a, b in zip(_ticked(session, 20), _ticked(fresh, 20), strict=True)
    )


def test_a_fall_is_detected_and_turns_the_torques_off_until_reset() -> None:
    """80 N sideways on 2.5 kg Solo12 for 2 s: it tips over within ~0.2 s. The fall protection
    turns the torques off, damps the limp joints and ends the push; the robot tumbles on and comes
    to rest. The tumble is chaotic (its path differs from one processor to the next), so this
    checks outcomes: the fall, the torques, the clock, the joints' speed, no divergence."""
    session = Session(SessionConfig(robot="solo12"))
    session.handle("push", {"body": "base_link", "force": [0.0, 80.0, 0.0], "duration": 2.0})
    assert session.handle("velocity", {"vx": 0.2, "vy": 0.0, "yaw_rate": 0.1})["ok"]
    times = []
    for _ in range(2000):
        session.tick()
        times.append(session.time)
    assert session.fell
    # While it tips, a level's QP may fail and keep the levels above (solver_fallback): shown,
    # not an error. One fall, no sim_diverged.
    events = [e for e in session.pop_events() if e["type"] != "solver_fallback"]
    assert [e["type"] for e in events] == ["fall"]
    assert events[0]["t"] < 1.0  # s: measured 0.21-0.22 s over 10 runs from perturbed starts
    assert session.divergences == 0
    assert np.all(np.diff(times) > 0.0) and session.time == pytest.approx(2.0, abs=1e-9)
    assert np.all(session.tau == 0.0)
    telemetry = session.telemetry()
    assert telemetry["pushes"] == [] and not session.plant.mj_data.xfrc_applied.any()
    # the velocity command ended too: a robot reset to standing must not walk off
    assert telemetry["command"] == {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0}
    # Telemetry follows the fallen robot (it read the state of the fall's tick before): the
    # model holds the state before the last step: one step apart at < 1.5 m/s (below).
    q, v = session.plant.state()
    assert telemetry["base"]["position"] == pytest.approx(q[:3].tolist(), abs=1.5e-3)
    # Damped limp joints (≤ 2.3 rad/s at 2 s over 10 perturbed runs; undamped, Solo12's shanks
    # spun at up to 900 rad/s and MuJoCo diverged) and a robot coming to rest: ≤ 0.46 m/s at 2 s
    # over those runs, from 6.9 m/s when it fell.
    assert np.abs(v[6:]).max() < 20.0  # rad/s
    assert np.linalg.norm(telemetry["base"]["linear_velocity"]) < 1.5  # m/s
    assert session.handle("reset")["ok"]
    run(session, 0.5)
    assert not session.fell and np.abs(session.tau).max() > 0.1  # standing under control again
    assert np.all(session.plant.mj_model.dof_damping == 0.0)  # the controller's model again


def test_a_diverging_simulation_is_an_event_and_the_clock_goes_on() -> None:
    """A state MuJoCo flags as bad (here injected: a huge joint speed, then NaN) is detected
    before MuJoCo could reset itself: a sim_diverged event names the cause, the robot stands
    again at the same sim time and the session keeps ticking; a second divergence within
    DIVERGENCE_REPEAT_S pauses it until reset."""
    session = Session(SessionConfig(robot="anymal"))
    run(session, 0.3)
    before = session.time
    session.plant.mj_data.qvel[8] = 1e12  # rad/s: beyond what MuJoCo accepts (1e10)
    session.tick()
    events = session.pop_events()
    assert [e["type"] for e in events] == ["sim_diverged"]
    diverged = events[0]
    assert "velocity" in diverged["cause"] and diverged["restored"] == "standing"
    assert before <= diverged["t"] <= before + 2e-3 and session.time == diverged["t"]
    assert session.divergences == 1 and not session.paused
    assert session.telemetry()["divergences"] == 1
    run(session, 0.5)
    assert session.time == pytest.approx(diverged["t"] + 0.5, abs=1e-9)
    assert not session.fell and session.qp_failures == 0
    height = session.telemetry()["base"]["position"][2]
    assert abs(height - session.robot.q_standing[2]) < 0.02  # m: standing again
    # Again within DIVERGENCE_REPEAT_S: paused (the clock stops, it never runs backwards).
    session.plant.mj_data.qpos[0] = math.nan
    session.tick()
    again = session.pop_events()[0]
    assert again["type"] == "sim_diverged" and again["restored"] == "paused"
    assert "position" in again["cause"] and session.paused
    paused_at = session.time
    assert paused_at >= diverged["t"] + 0.5
    run(session, 0.1)
    assert session.time == paused_at and np.all(np.isfinite(session.plant.state()[1]))
    assert session.handle("reset")["ok"] and not session.paused
    run(session, 0.1)
    assert not session.fell and session.divergences == 2


@pytest.mark.parametrize("damped", [True, False])
def test_a_fallen_robots_limp_joints_are_braked(damped: bool) -> None:
    """A fallen Solo12's joints are damped (b = τ_max / LIMP_DAMPING_SPEED): set spinning at
    10 × LIMP_DAMPING_SPEED, they turn at 1.5-3 rad/s on average 50 ms later (falls from 60-100 N
    pushes). Undamped (the control case) the light legs keep swinging at 32-79; under a sustained
    push they spun up to 6e5 rad/s and MuJoCo diverged in every run (docs/architecture.md,
    "Faults")."""
    session = Session(SessionConfig(robot="solo12"))
    if not damped:
        session.plant.set_joint_damping = lambda damping: None
    session.handle("push", {"body": "base_link", "force": [0.0, 80.0, 0.0], "duration": 0.5})
    run(session, 1.0)
    assert session.fell
    q, v = session.plant.state()
    alternating = np.where(np.arange(v.size - 6) % 2 == 0, 1.0, -1.0)
    v[6:] = 10 * LIMP_DAMPING_SPEED * alternating
    session.plant.reset(q, v, time=session.time)
    run(session, 0.05)
    mean_speed = np.abs(session.plant.state()[1][6:]).mean()  # rad/s
    if damped:
        assert mean_speed < LIMP_DAMPING_SPEED / 2
    else:
        assert mean_speed > LIMP_DAMPING_SPEED


@pytest.mark.parametrize(
    ("touch_s", "falls"), [(FALL_CONTACT_S - 0.2, False), (FALL_CONTACT_S + 0.1, True)]
)
def test_a_shin_on_the_ground_is_a_fall_only_when_it_stays(
    monkeypatch, touch_s: float, falls: bool
) -> None:
    """A stumble (a shin grazing a tile edge) is not a fall; resting on it is (FALL_CONTACT_S)."""
    session = Session(SessionConfig(robot="anymal"))
    session.native_ticks = False  # the plant's call is faked: the Python tick makes it
    run(session, 0.1)
    monkeypatch.setattr(session.plant, "non_foot_ground_contact", lambda: True)
    run(session, touch_s)
    monkeypatch.undo()
    run(session, 0.1)
    assert session.fell is falls


def test_telemetry_is_json_and_physical(session: Session) -> None:
    session.handle("reset")
    run(session, 0.3)
    telemetry = json.loads(json.dumps(session.telemetry()))
    weight = session.model.mass * 9.81
    measured = sum(c["measured_force"][2] for c in telemetry["contacts"])
    planned = sum(c["force"][2] for c in telemetry["contacts"])
    assert measured == pytest.approx(weight, rel=0.02)
    assert planned == pytest.approx(weight, rel=0.02)
    feet = np.array([c["position"][:2] for c in telemetry["contacts"]])
    cop = np.array(telemetry["cop"]["net"][:2])
    assert np.all(cop > feet.min(axis=0)) and np.all(cop < feet.max(axis=0))
    assert np.linalg.norm(telemetry["momentum"]["linear"]) < 0.05 * session.model.mass


def test_standing_starts_where_the_robot_is_and_faces() -> None:
    """Switching to `stand` holds the current place and heading, not the world origin."""
    session = Session(SessionConfig(robot="anymal"))
    q = session.robot.q_standing.copy()
    q[:2] = [0.5, -0.3]
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, 0.4)).coeffs()
    session.plant.reset(q)
    assert session.handle("gait", {"name": "stand"})["ok"]
    run(session, 1.0)
    base = session.telemetry()["base"]
    assert not session.fell
    assert np.linalg.norm(np.array(base["position"][:2]) - q[:2]) < 0.01
    yaw = pin.rpy.matrixToRpy(pin.Quaternion(np.array(base["quaternion"])).toRotationMatrix())[2]
    assert abs(yaw - 0.4) < 0.01


def test_a_walking_gait_brings_a_stack_that_can_swing_feet() -> None:
    """The robots' default stacks are for standing (no swing_feet task): trotting on one, a
    swinging leg is uncontrolled and ANYmal falls within ~1 s. The gait command installs
    Raiola's S3 then, and says so."""
    session = Session(SessionConfig(robot="anymal"))
    reply = session.handle("gait", {"name": "trot"})
    assert reply["ok"] and reply["preset"] == "raiola_s3"
    assert ["contact", "swing_feet"] in reply["stack"]
    assert session.telemetry()["stack"] == reply["stack"]
    session.handle("velocity", {"vx": 0.4})
    x0 = session.model.q[0]
    run(session, 2.5)
    assert not session.fell and session.qp_failures == 0
    assert session.model.q[0] - x0 > 0.5  # m in 2.5 s at 0.4 m/s, accelerating from rest
    # A stack that can already swing feet is kept as it is.
    assert session.handle("stack", {"preset": "hutter_table7"})["ok"]
    reply = session.handle("gait", {"name": "crawl"})
    assert reply == {"ok": True}
    assert ["base_height"] in session.telemetry()["stack"]


def test_a_stack_preset_brings_its_levels_gains_and_method() -> None:
    session = Session(SessionConfig(robot="anymal"))
    before = session.info()
    assert not session.handle("stack", {"preset": "no_such_preset"})["ok"]
    both = session.handle("stack", {"preset": "raiola_s1", "levels": [["contact"]]})
    assert not both["ok"] and "not both" in both["error"]
    assert session.info()["stack"] == before["stack"]  # rejected: nothing changed
    assert "raiola_s1" in before["stack_presets"]
    reply = session.handle("stack", {"preset": "raiola_s1"})
    assert reply["ok"] and reply["hierarchy"]["method"] == "weighted"
    info = session.info()
    assert info["stack"] == reply["stack"] and "moving_posture" in info["stack"][-1]
    gains = {task["name"]: task for task in info["tasks"]}
    assert gains["swing_feet"]["weight"] == 1e6  # stacks/raiola_s1.toml
    # A gain a task does not read is null: the UI hides it.
    assert gains["forces"]["gains"] == ["weight"] and gains["forces"]["kp"] is None
    assert gains["contact"]["kp"] is None and gains["contact"]["kd"] is not None


def test_the_foot_forces_reach_the_controller_only_while_a_task_reads_them() -> None:
    """The session measures the feet's forces for the controller only while the internal-force
    task (Kim eq. 12) is in the stack, and then every tick: standing, they carry the weight."""
    session = Session(SessionConfig(robot="anymal"))
    run(session, 0.05)
    task = session.controller.internal_force
    assert task.measured_forces is None
    levels = [*session.controller.config.stack.as_lists(), ["internal_force"]]
    assert session.handle("stack", {"levels": levels})["ok"]
    run(session, 0.05)
    weight = session.model.mass * 9.81
    assert task.measured_forces[:, 2].sum() == pytest.approx(weight, rel=0.1)


def test_a_reset_starts_the_nullspace_search_cold(monkeypatch) -> None:
    """The nullspace method starts each tick from the last tick's active rows and x; after a
    reset the robot stands anew and the first tick starts cold, not from the state left (the
    Python kernel's; tests/kernel/test_kernel_nullspace.py has the native kernel's)."""
    starts: list[bool] = []
    nullspace = hierarchy.METHODS["nullspace"]

    def spy(problem: hierarchy.HierarchyProblem, solver: str) -> hierarchy.HierarchySolution:
        starts.append(problem.x_start is not None or len(problem.active_start) > 0)
        return nullspace(problem, solver)

    monkeypatch.setitem(hierarchy.METHODS, "nullspace", spy)
    session = Session(SessionConfig(robot="anymal", method="nullspace", kernel="python"))
    session.handle("push", {"body": "base", "force": [0.0, 150.0, 0.0], "duration": 0.05})
    run(session, 0.02)
    assert starts[0] is False and all(starts[1:])
    starts.clear()
    assert session.handle("reset")["ok"]
    run(session, 0.002)
    assert starts == [False, True]


def test_a_session_dropped_frees_its_native_parts_at_once() -> None:
    """No reference cycle holds a session: dropped, it and its native parts (the kernel, the
    plant's step, the frame placements, the last tick's outcome) are freed at once, with the
    garbage collector off. A cycle through a native object is invisible to the collector and
    would keep them to the interpreter's exit, where nanobind reports them as leaked."""
    gc.disable()
    try:
        session = Session(SessionConfig(robot="talos"))
        alive = []
        for command, payload in (("stance", {"side": "left"}), ("gait", {"name": "trot"})):
            assert session.handle(command, payload)["ok"]
            run(session, 0.01)
            session.telemetry(), session.drawing_state(), session.solution
            parts = (
                session.controller,
                session.plant,
                session.frame_placements,
                session.native_tick,  # the server tick in one crossing (lab._kernel.ServerTick)
            )
            alive += [weakref.ref(part) for part in parts]
            assert session.handle("robot", {"name": "anymal"})["ok"]  # a rebuild drops them
        alive.append(weakref.ref(session))
        del session, parts
        assert [ref() for ref in alive] == [None] * len(alive)
    finally:
        gc.enable()


def test_reset_after_stepping_stands_on_the_robots_default_stack() -> None:
    """Bolt under biped_step runs kim_stepping (no CoM task): Reset returns to standing with
    the default stack, gains and method, and Bolt stands (it fell 1.4 s after every Reset).
    A stack the user chose stays."""
    session = Session(SessionConfig(robot="bolt"))
    default = session.controller.config.stack.as_lists()
    assert session.handle("gait", {"name": "biped_step"})["ok"]
    assert session.controller.config.method == "wbosc"
    run(session, 0.3)
    reply = session.handle("reset")
    assert reply["ok"] and reply["stack"] == default
    assert session.controller.config.method == "cascade" and session.behaviour.name == "stand"
    assert "default stack" in session.pop_events()[-1]["message"]
    run(session, 3.0)
    assert not session.fell
    chosen = [["friction", "torque_limits"], ["contact"], ["com", "base_orientation", "posture"]]
    assert session.handle("stack", {"levels": chosen})["ok"]
    assert session.handle("reset") == {"ok": True}
    assert session.controller.config.stack.as_lists() == chosen
