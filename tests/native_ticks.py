"""The agreement tests' way to run a behaviour's native tick beside its Python one."""

import numpy as np

from lab.controller.model import RobotModel
from lab.server.session import Session

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
