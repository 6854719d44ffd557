"""The biped stepping behaviour's native tick (cpp/behaviours/biped_step.cpp, pipm.cpp,
swing.cpp) against its Python steps (biped_step.py, pipm.py), and Bolt stepping on native
ticks in a session. Skipped when the kernel is not built."""

import functools

import numpy as np
import pytest

from lab.controller.behaviours import biped_step as biped_module
from lab.controller.behaviours.biped_step import BipedStepping
from lab.controller.model import RobotModel
from lab.world.session import Session, SessionConfig
from tests.helpers.native_ticks import recording, tick_native_and_mixed

pytest.importorskip("lab._kernel", reason="the native kernel is not built (./dev builds it)")

TOL = 1e-9  # relative to 1 + |value|: the same steps, another float order
RECORDED_TICKS = 2000  # 2 s of Bolt stepping: seven steps, each planned and replanned
TURN_AT = 500  # the command turns from here on
PUSH_AT = 1200  # a sideways push: the lateral planner cuts a swing short


@functools.cache
def recorded_walk() -> tuple:
    """What a Python-kernel Bolt session's stepping behaviour was given per tick while it
    stepped in place, then walked forward and turned under Kim's stack (wbosc), pushed sideways:
    (t, q, v, command, touching)."""
    session = Session(SessionConfig(robot="bolt", kernel="python"))
    session.handle("gait", {"name": "biped_step"})
    calls = recording(session)
    for tick in range(RECORDED_TICKS):
        if tick == TURN_AT:
            session.handle("velocity", {"vx": 0.2, "yaw_rate": 0.3})
        if tick == PUSH_AT:
            session.handle("push", {"body": "base_link", "force": [0, 1.5, 0], "duration": 0.1})
        session.tick()
    assert not session.fell
    return session.robot, tuple(calls)


def stepping_state(stepping: BipedStepping) -> dict[str, object]:
    """Everything a stepping tick changes: its state and the references (NaN weights as −1)."""
    refs = stepping.references
    return {
        "t": stepping.t,
        "yaw": stepping.yaw,
        "since": stepping.since,
        "liftoff": stepping.liftoff,
        "target": stepping.target,
        "swing_clock": (
            stepping.swing_start,
            stepping.swing_t0,
            stepping.swing_u0,
            stepping.swing_duration,
        ),
        "counts": (stepping.steps, stepping.plans, stepping.shortened, stepping.lengthened),
        "plan": stepping.plan,
        "force_weight": np.nan_to_num(refs.force_weight, nan=-1.0),
        "foot_position": refs.foot_position,
        "foot_velocity": refs.foot_velocity,
        "foot_acceleration": refs.foot_acceleration,
        "posture": refs.posture,
        "base_height": refs.base_height,
        "base_rotation": refs.base_rotation,
        "base_angular_velocity": refs.base_angular_velocity,
        "com": refs.com,
    }


def assert_same_stepping(native: BipedStepping, python: BipedStepping, tick: int) -> None:
    assert (native.phase, native.swing) == (python.phase, python.swing), tick
    for flags in ("contact_active", "swing_tracked"):
        expected = getattr(python.references, flags)
        assert np.array_equal(getattr(native.references, flags), expected), (flags, tick)
    actual = stepping_state(native)
    for name, value in stepping_state(python).items():
        reference = np.asarray(value, dtype=float)
        atol = TOL * (1.0 + np.abs(reference).max())
        got = np.asarray(actual[name], dtype=float)
        # the quick check first (numpy.testing costs most of the test's time otherwise); what
        # it does not accept (a NaN, another shape, a difference) goes to assert_allclose
        if got.shape == reference.shape and np.all(np.abs(got - reference) <= atol):
            continue
        np.testing.assert_allclose(
            got, reference, rtol=0, atol=atol, err_msg=f"{name} at tick {tick}"
        )


def test_the_native_stepping_tick_agrees_with_python() -> None:
    """Three steppings given a recorded walk (lift-offs, touchdowns, a turn, replanning every
    tick from 80 % of the lift, swings cut short): one runs every tick in Python, one every
    tick natively, one alternates in blocks. Every state and reference stays equal within
    1e-9."""
    assert biped_module.NativeBipedStepping is not None, "the kernel lacks BipedStepping"
    robot, calls = recorded_walk()
    model = RobotModel(robot.model, robot.contacts)
    model.update(robot.q_standing, np.zeros(robot.model.nv))
    python, native, mixed = (BipedStepping(model, robot.q_standing) for _ in range(3))
    for tick, (t, q, v, command, touching) in enumerate(calls):
        model.update(q, v)
        python.update(t, model, command, touching)
        tick_native_and_mixed(tick, model, native, mixed, t, command, touching)
        assert_same_stepping(native, python, tick)
        assert_same_stepping(mixed, python, tick)
    assert python.steps >= 6 and python.plans >= 50
    assert python.shortened + python.lengthened >= 1
    assert native.prediction.foot == pytest.approx(python.prediction.foot, abs=1e-9)


def test_bad_stepping_state_raises_a_clear_error() -> None:
    robot, calls = recorded_walk()
    model = RobotModel(robot.model, robot.contacts)
    model.update(robot.q_standing, np.zeros(robot.model.nv))
    stepping = BipedStepping(model, robot.q_standing)
    t, q, v, command, touching = calls[0]
    model.update(q, v)
    model.filled_elsewhere()
    stepping.plan = np.zeros(3)
    with pytest.raises(ValueError, match="plan"):
        stepping.update(t, model, command, touching)


def test_bolt_steps_and_turns_on_native_ticks() -> None:
    """Bolt under `biped_step` on Kim's stack run by the native cascade: the stepping tick runs
    in C++, and Bolt steps and turns for 4 s without falling."""
    session = Session(SessionConfig(robot="bolt"))
    session.handle("gait", {"name": "biped_step"})
    session.handle("hierarchy", {"method": "cascade"})
    session.handle("velocity", {"vx": 0.2, "yaw_rate": 0.3})
    while session.time < 4.0 and not session.fell:
        session.tick()
    assert session.controller.kernel_ran == "native"
    assert not session.behaviour._native_stale  # the native stepping tick ran
    assert not session.fell and session.behaviour.steps >= 10


def test_lab_bench_has_a_bolt_stepping_row_on_the_native_tick() -> None:
    """`lab bench`'s Bolt row with gait biped_step: it says its gait, ran the native kernel
    (the stepping tick included) and did not fall in 1 s of walking and turning."""
    from lab.experiments.bench import bench_one

    row = bench_one("bolt", "cascade", 1.0, "native", "biped_step")
    assert (row["gait"], row["kernel"], row["fell"]) == ("biped_step", "native", False)
    assert row["kernel_us"] is not None
