"""The agreement tests' way to run a behaviour's native tick beside its Python one."""

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel
from lab.world.session import Session

SWITCH_BLOCK = 37  # ticks per kernel in the behaviour that alternates Python and native ticks


def recording(session: Session) -> list[tuple]:
    """Record what the session's behaviour is given from now on: each tick appends
    (t, q, v, command, touching) to the returned list, then the behaviour updates."""
    calls = []
    update = session.behaviour.update

    def record(t, robot, command, touching) -> None:
        calls.append((t, robot.q.copy(), robot.v.copy(), command.copy(), touching.copy()))
        update(t, robot, command, touching)

    session.behaviour.update = record
    return calls


def tick_native_and_mixed(
    tick: int,
    model: RobotModel,
    native: object,
    mixed: object,
    t: float,
    command: np.ndarray,
    touching: np.ndarray,
) -> None:
    """After the Python behaviour's tick on `model` (its Python update): `mixed` ticks in
    Python or natively, in blocks of SWITCH_BLOCK ticks, and `native` always natively (the
    model is marked as filled by the native kernel's update, so their native tick runs)."""
    on_native = (tick // SWITCH_BLOCK) % 2 == 1
    if not on_native:
        mixed.update(t, model, command, touching)
    model.filled_elsewhere()  # as after the native kernel's update: the native tick runs
    native.update(t, model, command, touching)
    if on_native:
        mixed.update(t, model, command, touching)
    assert not native._native_stale, "the native tick did not run"


def scripted_state(q_standing: np.ndarray, t: float, speed: float = 0.0) -> tuple:
    """A robot state (q, v) at time `t` (s) of a scripted, unsimulated motion about the standing
    posture `q_standing`: the base moves forward at `speed` (m/s) and turns slowly, its height,
    roll and pitch wobble by a few mm and mrad, every joint swings by 0.02 rad; v is its rate
    (base twist in the base frame, as pinocchio's v). The inputs of an agreement test that
    needs no simulation."""
    wobble, turn = np.sin(2.0 * np.pi * 0.7 * t), 0.1
    roll, pitch, yaw = 0.01 * wobble, -0.008 * wobble, turn * t
    rates = 2.0 * np.pi * 0.7 * np.cos(2.0 * np.pi * 0.7 * t)
    q = q_standing.copy()
    q[0] += speed * t
    q[2] += 0.004 * wobble
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(roll, pitch, yaw)).coeffs()
    q[7:] += 0.02 * np.sin(2.0 * np.pi * 0.5 * t + np.arange(len(q) - 7))
    v = np.zeros(len(q) - 1)
    rotation = pin.rpy.rpyToMatrix(roll, pitch, yaw)
    v[:3] = rotation.T @ np.array([speed, 0.0, 0.004 * rates])
    v[3:6] = rotation.T @ np.array([0.01 * rates, -0.008 * rates, turn])  # small angles: ≈ rates
    v[6:] = 0.02 * 2.0 * np.pi * 0.5 * np.cos(2.0 * np.pi * 0.5 * t + np.arange(len(q) - 7))
    return q, v
