"""The server's native tick (lab/world/native_tick.py, cpp/plant/server_tick.cpp) against the
Python tick, the reference: from the same state, tick by tick, the same torques, planned forces
and next state, with the realism layer ideal and with every knob on; the same events from the
same faults; and the tick path reported."""

import math

import mujoco
import numpy as np
import pytest

from lab.realism.knobs import RealismKnobs, knobs_from, preset
from lab.realism.layer import RealismLayer
from lab.world.native_tick import HAS_SERVER_TICK
from lab.world.session import Session, SessionConfig
from lab.world.session_tick import FALL_CHECK_PERIOD

pytestmark = pytest.mark.skipif(not HAS_SERVER_TICK, reason="lab._kernel has no ServerTick")

STATE = mujoco.mjtState.mjSTATE_INTEGRATION  # qpos, qvel, act, warm start, ctrl, time, forces


def pair(
    config: SessionConfig, gait: str | None, command: dict | None, payload: dict | None = None
) -> tuple[Session, Session]:
    """Two sessions of `config` walking `gait` under velocity `command` (carrying `payload` if
    given): one on native ticks, one on Python ticks."""
    sessions = Session(config), Session(config)
    sessions[1].native_ticks = False
    for session in sessions:
        if payload is not None:
            assert session.handle("payload", payload)["ok"]
        if gait is not None:
            assert session.handle("gait", {"name": gait})["ok"]
        if command is not None:
            assert session.handle("velocity", command)["ok"]
    return sessions


def copy_physics(source: Session, target: Session) -> None:
    """The target's MuJoCo state becomes the source's (integration state and the last step's
    contacts, which the touch sensing reads)."""
    m, d = source.plant.mj_model, source.plant.mj_data
    state = np.empty(mujoco.mj_stateSize(m, STATE))
    mujoco.mj_getState(m, d, state, STATE)
    mujoco.mj_setState(target.plant.mj_model, target.plant.mj_data, state, STATE)


def agreement(native: Session, python: Session, ticks: int) -> dict[str, float]:
    """Per tick, from the native session's state copied into the Python one: the largest
    differences of τ, planned F and the next (qpos, qvel) over `ticks` ticks, each relative to
    its scale, and `lifted`, the ticks with a foot out of contact; asserts each tick ran the
    path it should."""
    worst = dict.fromkeys(("tau", "applied", "forces", "qpos", "qvel", "lifted"), 0.0)
    for _ in range(ticks):
        copy_physics(native, python)
        native.tick()
        python.tick()
        assert native.tick_report() == {"tick": "native", "tick_note": ""}
        assert python.tick_report()["tick"] == "python"
        pairs = {
            "tau": (native.tau, python.tau),
            "applied": (native.applied_tau, python.applied_tau),
            "forces": (native.forces, python.forces),
            "qpos": (native.plant.mj_data.qpos, python.plant.mj_data.qpos),
            "qvel": (native.plant.mj_data.qvel, python.plant.mj_data.qvel),
        }
        worst["lifted"] += not all(native.controller.references.contact_active)
        for name, (a, b) in pairs.items():
            scale = max(1.0, float(np.max(np.abs(b))))
            worst[name] = max(worst[name], float(np.max(np.abs(a - b))) / scale)
    return worst


@pytest.mark.parametrize(
    ("robot", "gait", "command"),
    [
        ("anymal", None, None),  # standing: Balance idle, the controller's compute
        ("anymal", "trot", {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.2}),
        ("bolt", "biped_step", {"vx": 0.2, "vy": 0.0, "yaw_rate": 0.0}),
    ],
)
def test_the_native_tick_agrees_with_the_python_tick(robot, gait, command) -> None:
    """300 ticks after a warm-up (the trot's legs in swing and stance, Bolt stepping): each
    tick from the same state gives the same τ, F and next state, to 1e-12 of their scale (both
    paths run the same kernel, behaviour twin and MuJoCo step: bit for bit on this machine; the
    tolerance leaves room for a compiler's reordering of sums)."""
    native, python = pair(SessionConfig(robot=robot), gait, command)
    for _ in range(200):  # warm-up, both on their own path: the behaviours start their clocks
        copy_physics(native, python)
        native.tick()
        python.tick()
    worst = agreement(native, python, 300)
    assert max(worst[name] for name in ("tau", "forces", "qpos", "qvel")) < 1e-12, worst
    assert not native.fell and native.qp_ok
    if gait is not None:  # feet really swung on the native ticks compared
        assert worst["lifted"] > 50, worst


def test_talos_on_one_sole_under_lqr_runs_the_native_tick_and_agrees() -> None:
    """Talos shifting onto its left sole (Herzog Table 4, the LQR momentum law: `lab bench`'s
    `single` row), pushed sideways: every tick is one crossing, the kernel asking the Python
    gain schedule from inside it only where K_h changes (a redesign as the CoG moves and its
    interpolation), and each tick from the same state agrees with the Python tick to 1e-9 of
    its scale."""
    native, python = pair(SessionConfig(robot="talos"), None, None)
    for session in (native, python):
        assert session.handle("momentum", {"mode": "lqr"})["ok"]
        assert session.handle("stance", {"side": "left"})["ok"]
    task = native.controller.tasks["momentum"]
    asked = []
    schedule_tick = task._schedule_tick
    task._schedule_tick = lambda steps: asked.append(1) or schedule_tick(steps)  # the kernel's
    for _ in range(100):
        copy_physics(native, python)
        native.tick()
        python.tick()
    for session in (native, python):
        push = {"body": session.robot.base_link, "force": [0.0, 150.0, 0.0], "duration": 0.035}
        assert session.handle("push", push)["ok"]
    worst = agreement(native, python, 300)
    assert max(worst[name] for name in ("tau", "forces", "qpos", "qvel")) < 1e-9, worst
    assert not native.fell and native.qp_ok
    # the first tick designs; the settled ticks after it do not ask
    assert 1 <= len(asked) < 400, len(asked)


def every_knob(robot: str) -> RealismKnobs:
    """`harsh` for `robot` with the series elastic actuator: every sensor, delay, actuator,
    drive-limit and model-error knob on (the contact estimate aside: standing reads no touch;
    the trots below have it)."""
    sea = {"actuator": "sea", "sea_stiffness": 200.0, "sea_motor_inertia": 0.05}
    return knobs_from(preset("harsh", robot), {**sea, "sea_kp": 1800.0, "sea_kd": 10.0})


@pytest.mark.parametrize(
    ("robot", "knobs", "gait", "command"),
    [
        ("anymal", every_knob("anymal"), None, None),
        ("anymal", preset("typical", "anymal"), "trot", {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0}),
        # Bolt's `typical` reads its base from the EKF: its C++ twin on both paths
        ("bolt", preset("typical", "bolt"), "biped_step", {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0}),
        (
            "anymal",
            knobs_from(preset("typical", "anymal"), {"estimator": "ekf"}),
            "trot",
            {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0},
        ),
        # touchdown from the estimated contact forces: the C++ detector in the crossing
        (
            "anymal",
            knobs_from(preset("typical", "anymal"), {"contact_estimate": 1}),
            "trot",
            {"vx": 0.5, "vy": 0.0, "yaw_rate": 0.0},
        ),
        (
            "hyq",
            knobs_from(preset("typical", "hyq"), {"contact_estimate": 1}),
            "trot",
            {"vx": 0.5, "vy": 0.0, "yaw_rate": 0.0},
        ),
    ],
    ids=[
        "anymal-every-knob",
        "anymal-trot-typical",
        "bolt-step-typical",
        "anymal-trot-ekf",
        "anymal-trot-touch-estimate",
        "hyq-trot-touch-estimate",
    ],
)
def test_the_native_tick_with_realism_agrees_with_the_python_tick(
    robot, knobs, gait, command
) -> None:
    """With the realism layer on (same seed; a 2 kg payload on the base as well), the native
    tick, which calls the C++ layer (and the EKF's twin under `ekf`) inside its one crossing,
    gives the Python tick's τ, applied torques, F and next state, tick by tick, to 1e-12 of their
    scale: the Python tick calls the same C++ layer and EKF from Python, so the two differ only
    in the path (and under `contact_estimate` in the touch detector: the Python one against its
    C++ twin, the same touchdowns at the same ticks or τ would differ by newton-metres)."""
    base = {"body": "base", "mass": 2.0, "offset": [0.0, 0.0, 0.05]}
    payload = base if robot == "anymal" else None
    native, python = pair(SessionConfig(robot=robot, realism=knobs), gait, command, payload)
    for _ in range(200):
        copy_physics(native, python)
        native.tick()
        python.tick()
    assert native.realism.kernel == "native" and not native.realism.ideal
    worst = agreement(native, python, 300)
    assert max(worst[name] for name in ("tau", "applied", "forces", "qpos", "qvel")) < 1e-12
    assert not native.fell and native.qp_ok
    # the layer acted: the applied torques are not the commanded ones
    assert np.max(np.abs(native.applied_tau - native.tau)) > 1e-3
    if gait is not None:
        assert worst["lifted"] > 50, worst


def test_touchdown_from_the_estimate_continues_across_a_switch_of_tick_path() -> None:
    """ANYmal trotting at 0.5 m/s under `typical` with `contact_estimate`: a session whose
    ticks switch between the native and the Python path every 37 ticks (the detector's state
    handed over each way, the native tick's `applied` buffer written by the Python ticks) gives,
    tick by tick from the same state, the τ, applied torques and next state of one that stays
    native, to 1e-12 of their scale, and the same touch flags."""
    knobs = knobs_from(preset("typical", "anymal"), {"contact_estimate": 1})
    trot = {"vx": 0.5, "vy": 0.0, "yaw_rate": 0.0}
    native, switching = pair(SessionConfig(robot="anymal", realism=knobs), "trot", trot)
    for _ in range(100):  # warm-up, both native (a gait's first tick makes its twin)
        copy_physics(native, switching)
        native.tick()
        switching.tick()
    worst, paths, lifted = 0.0, set(), 0
    for tick in range(600):
        switching.native_ticks = (tick // 37) % 2 == 1
        copy_physics(native, switching)
        native.tick()
        switching.tick()
        paths.add(switching.tick_report()["tick"])
        assert native.tick_report()["tick"] == "native"
        assert native.touch_estimate is not None and switching.touch_estimate is not None
        assert np.array_equal(native.touch_estimate.touch, switching.touch_estimate.touch)
        lifted += not all(native.touch_estimate.touch)
        for a, b in (
            (native.tau, switching.tau),
            (native.applied_tau, switching.applied_tau),
            (native.plant.mj_data.qvel, switching.plant.mj_data.qvel),
        ):
            worst = max(worst, float(np.max(np.abs(a - b))) / max(1.0, float(np.max(np.abs(b)))))
    assert paths == {"native", "python"} and lifted > 100
    assert worst < 1e-12 and not native.fell


def test_the_native_tick_with_realism_agrees_with_the_python_layer() -> None:
    """The full reference: the Python tick with the Python realism layer (lab/realism/layer.py)
    against the native tick with the C++ one, ANYmal trotting under `typical` (SEA drives,
    every sensor knob, delays, friction, model error): each tick from the same state gives the
    same τ, F and next state to 1e-9 of their scale (the layers agree to 1e-12; a 17-bit
    encoder's rounding could amplify that, but only at a grid boundary)."""
    knobs = preset("typical", "anymal")
    trot = {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0}
    native, python = pair(SessionConfig(robot="anymal", realism=knobs), "trot", trot)
    python.realism = RealismLayer(knobs, python.model.na, python.config.timestep)
    python.realism.reset(python.robot.q_standing)
    for _ in range(100):
        copy_physics(native, python)
        native.tick()
        python.tick()
    worst = agreement(native, python, 200)
    assert max(worst[name] for name in ("tau", "applied", "forces", "qpos", "qvel")) < 1e-9
    assert not native.fell and native.qp_ok


@pytest.mark.parametrize(
    ("speed", "where"),
    [(math.nan, "before the step"), (5e9, "after the step: MuJoCo flags the acceleration")],
)
def test_a_divergence_on_a_native_tick_gives_the_python_ticks_events(speed, where) -> None:
    """A joint speed set from outside (NaN: caught before control; 5e9 rad/s: finite, caught
    after the step): the native tick gives the Python tick's events (sim_diverged with its
    cause, and what the controller reported on the way), at the same sim times, and the robot
    stands again on native ticks."""
    events, counted = [], []
    for native_ticks in (True, False):
        session = Session(SessionConfig(robot="anymal"))
        session.native_ticks = native_ticks
        for _ in range(20):
            session.tick()
        session.pop_events()
        session.plant.mj_data.qvel[8] = speed
        session.tick()
        assert session.divergences == 1, where
        events.append(session.pop_events())
        counted.append(sum(session.ran_ticks.values()))
        for _ in range(20):
            session.tick()
        assert session.tick_report()["tick"] == ("native" if native_ticks else "python")
        assert abs(session.model.q[2] - session.robot.q_standing[2]) < 0.02
    assert events[0] == events[1] and any(e["type"] == "sim_diverged" for e in events[0])
    assert counted[0] == counted[1]


def test_a_solver_failure_on_native_ticks_falls_back_as_on_python_ticks() -> None:
    """Weighted, infeasible contact limits (a normal force of at least 200 N and at most 100 N)
    for 30 ticks: each native tick fails as a Python tick does (fallback torques, the same
    solver_failure event and count), and the native ticks carry on after."""
    reports = []
    for native_ticks in (True, False):
        session = Session(SessionConfig(robot="anymal"))
        session.native_ticks = native_ticks
        assert session.handle("hierarchy", {"method": "weighted"})["ok"]
        for _ in range(50):
            session.tick()
        limits = session.controller.config.limits
        sane = (limits.normal_min, limits.normal_max)
        limits.normal_min, limits.normal_max = 200.0, 100.0
        for _ in range(30):
            session.tick()
        assert session.qp_failures == 30 and not session.qp_ok
        failures = [e for e in session.pop_events() if e["type"] == "solver_failure"]
        limits.normal_min, limits.normal_max = sane
        for _ in range(300):
            session.tick()
        assert session.qp_ok and not session.fell
        assert session.tick_report()["tick"] == ("native" if native_ticks else "python")
        reports.append(failures)
    assert reports[0] == reports[1] and reports[0]  # kinds, messages, counts and sim times


def test_the_python_tick_runs_and_says_why_when_the_native_one_cannot() -> None:
    """The Python kernel and a push at a point (its lever arm is set in Python each step) each
    run the Python tick, and telemetry's `ran` and `info` name the reason; every behaviour has a
    native twin, so Hutter's height step runs native."""
    session = Session(SessionConfig(robot="anymal"))
    session.tick()
    assert session.telemetry()["ran"]["tick"] == "native"
    assert session.handle("hierarchy", {"kernel": "python"})["ok"]
    session.tick()
    ran = session.telemetry()["ran"]
    assert ran["tick"] == "python" and "python" in ran["tick_note"]
    assert session.handle("hierarchy", {"kernel": "native"})["ok"]
    assert session.handle("gait", {"name": "height_step"})["ok"]
    session.tick()
    session.tick()
    assert session.telemetry()["ran"]["tick"] == "native"
    base = session.robot.base_link
    push = {"body": base, "force": [5.0, 0.0, 0.0], "duration": 0.5, "point": [0.0, 0.0, 0.6]}
    assert session.handle("push", push)["ok"]
    session.tick()
    ran = session.telemetry()["ran"]
    assert ran["tick"] == "python" and "push at a point" in ran["tick_note"]
    assert session.info()["tick"] == "python"


def test_the_native_tick_sees_a_body_other_than_a_foot_on_the_ground() -> None:
    """The fall check's contact test made in the native tick is the plant's: ANYmal let down
    onto its knees touches the ground with them (True), standing it does not (False); it falls
    by its height at the next fall check."""
    session = Session(SessionConfig(robot="anymal"))
    for _ in range(FALL_CHECK_PERIOD):  # standing, through one fall check
        session.tick()
        assert session.native_tick.non_foot_contact is False
    q = session.robot.q_standing.copy()
    q[2] = 0.2  # m: the base low, the knees on the ground
    session.plant.reset(q)
    for _ in range(FALL_CHECK_PERIOD - 1):
        session.tick()
        assert session.tick_report()["tick"] == "native"
        assert session.native_tick.non_foot_contact is True
        assert session.plant.non_foot_ground_contact()
    session.tick()
    assert session.fell


def test_an_exception_before_the_crossing_falls_back_on_this_ticks_state(monkeypatch) -> None:
    """The controller raises before the native tick's crossing (as a bug would) for 50 ticks:
    each falls back to the joint PD on the state the plant is in (not the last one the native
    tick read), the failures are counted, and the robot still stands after."""
    session = Session(SessionConfig(robot="anymal"))
    for _ in range(50):
        session.tick()
    monkeypatch.setattr(
        session.controller,
        "sync_native_tick",
        lambda: (_ for _ in ()).throw(RuntimeError("injected")),
    )
    for _ in range(50):
        q, v = session.plant.state()
        expected = session._fallback_torques(q, v)  # the joint PD at the state ticked from
        session.tick()
        assert np.allclose(session.tau, expected, rtol=0.0, atol=1e-9)
    assert session.qp_failures == 50 and "injected" in session.status.reason
    monkeypatch.undo()
    for _ in range(300):
        session.tick()
    assert session.qp_ok and session.tick_report()["tick"] == "native"
    assert abs(session.model.q[2] - session.robot.q_standing[2]) < 0.02


def test_a_realism_layer_in_python_runs_the_python_tick_and_says_why() -> None:
    """`typical` runs native (its C++ layer inside the crossing), with the touch estimate from
    torques too (its C++ twin, set on the crossing when the knob turns on); the Python layer
    swapped in runs the Python tick, and `ran` names why."""
    knobs = preset("typical", "anymal")
    session = Session(SessionConfig(robot="anymal", realism=knobs))
    session.tick()
    assert session.telemetry()["ran"]["tick"] == "native"
    assert session.handle("realism", {"contact_estimate": 1})["ok"]
    session.tick()
    assert session.telemetry()["ran"]["tick"] == "native"
    assert session.handle("realism", {"contact_estimate": 0})["ok"]
    session.tick()
    assert session.telemetry()["ran"]["tick"] == "native"
    session.realism = RealismLayer(knobs, session.model.na, session.config.timestep)
    session.realism.reset(session.plant.state()[0])
    session.tick()
    ran = session.telemetry()["ran"]
    assert ran["tick"] == "python" and "Python one" in ran["tick_note"]


def test_plain_native_ticks_decide_their_path_once_and_keep_results_until_read(
    monkeypatch,
) -> None:
    """The tick's path is decided when what it depends on changes, not every tick: the native
    tick's `note` runs once over 50 standing ticks, again after a command; τ and F read after
    a plain tick are that tick's (the kernel's buffers then), and stay so after the next tick
    (copies); the torques hold the robot up (the joints' τ within their limits, the planned
    normal forces summing to its weight within 5 %)."""
    session = Session(SessionConfig(robot="anymal"))
    native_tick, notes = session.native_tick, []
    note = native_tick.note

    def counted(*args: object) -> str:
        notes.append(args)
        return note(*args)

    monkeypatch.setattr(native_tick, "note", counted)
    for _ in range(50):
        session.tick()
    assert len(notes) == 1 and session.tick_report()["tick"] == "native"
    tau, forces = session.tau, session.forces
    assert np.array_equal(tau, native_tick.buffers["tau"])
    kept = tau.copy()
    session.tick()
    assert np.array_equal(tau, kept)  # that tick's copy, untouched by the next tick
    assert np.array_equal(session.tau, native_tick.buffers["tau"])
    assert np.all(np.abs(tau) <= session.robot.torque_limits)
    weight = session.model.mass * 9.81
    assert abs(forces[2::3].sum() - weight) < 0.05 * weight, forces
    assert session.handle("velocity", {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0})["ok"]
    session.tick()
    assert len(notes) == 2
    session.native_ticks = False  # a direct change: the next tick decides again
    session.tick()
    assert session.tick_report()["tick"] == "python"


def test_the_loops_warm_up_changes_nothing_of_the_session() -> None:
    """Session.warm (the server's loop calls it in its spin before each deadline) runs MuJoCo's
    forward dynamics on a scratch copy and changes nothing: an ANYmal trotting with a warm-up
    before every tick walks exactly as one without, tick by tick (the same MuJoCo state,
    torques and planned forces: one process, the same operations)."""
    warmed, cold = Session(SessionConfig(robot="anymal")), Session(SessionConfig(robot="anymal"))
    for session in (warmed, cold):
        assert session.handle("gait", {"name": "trot"})["ok"]
        assert session.handle("velocity", {"vx": 0.4, "vy": 0.0, "yaw_rate": 0.2})["ok"]
    native = 0  # the gait's first tick runs in Python (its twin starts with the gait's clock)
    for _ in range(400):
        warmed.warm()
        warmed.tick()
        cold.tick()
        native += warmed.tick_report()["tick"] == "native"
        for a, b in (
            (warmed.plant.mj_data.qpos, cold.plant.mj_data.qpos),
            (warmed.plant.mj_data.qvel, cold.plant.mj_data.qvel),
            (warmed.tau, cold.tau),
            (warmed.forces, cold.forces),
        ):
            np.testing.assert_array_equal(a, b)
    assert native >= 395
    assert warmed.plant._scratch is not None  # the warm-ups ran MuJoCo's forward dynamics
    assert not warmed.fell and warmed.time == pytest.approx(0.4)
