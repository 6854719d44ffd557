"""Per-joint limit overrides of a scenario: the torque and joint-position limits of an experiment.

A scenario's `[limits]` table narrows the robot's limits for an experiment (Hutter 2014 §5.1.3–4):

    [limits]
    torque = { KFE = 20.0 }               # N m, every joint named *_KFE
    position = { LF_HFE = [-1.0, 0.9] }   # rad, one joint

A key is a joint name or a suffix after '_' (`KFE` matches `LF_KFE`, ...). The overrides go into
the controller's `torque_limits` and `joint_limits` constraints, which act only where the stack
places them.
"""

import math

import numpy as np

from lab.controller.controller import WholeBodyController

LIMIT_KINDS = ("torque", "position")


class LimitsError(ValueError):
    """A limits table that is malformed or names no joint."""


def check_limits(raw: object) -> dict[str, dict[str, object]]:
    """Validate the shape of a `[limits]` table (names are checked against the robot later)."""
    if not isinstance(raw, dict):
        raise LimitsError("[limits] must be a table")
    unknown = set(raw) - set(LIMIT_KINDS)
    if unknown:
        raise LimitsError(f"[limits]: unknown keys {sorted(unknown)} (known: {LIMIT_KINDS})")
    for kind, table in raw.items():
        if not isinstance(table, dict):
            raise LimitsError(f"[limits] {kind} must be a table of joint = value")
        for joint, value in table.items():
            if kind == "torque":
                ok = isinstance(value, int | float) and math.isfinite(value) and value > 0
                what = "a positive torque (N m)"
            else:
                ok = (
                    isinstance(value, list)
                    and len(value) == 2
                    and all(isinstance(v, int | float) and math.isfinite(v) for v in value)
                    and value[0] < value[1]
                )
                what = "[lower, upper] with lower < upper (rad)"
            if not ok:
                raise LimitsError(f"[limits] {kind}.{joint} must be {what}, got {value!r}")
    return raw


def joints_matching(names: tuple[str, ...], key: str) -> np.ndarray:
    """Indices of the joints named `key` or ending in `_key`; raises when there is none."""
    found = [i for i, name in enumerate(names) if name == key or name.endswith("_" + key)]
    if not found:
        raise LimitsError(f"[limits]: no joint matches {key!r} (joints: {', '.join(names)})")
    return np.array(found)


def apply_limits(controller: WholeBodyController, limits: dict[str, dict[str, object]]) -> None:
    """Narrow the controller's torque and joint-position limits as the table says."""
    names = controller.robot.joint_names
    torque_limits = controller.torque_limits().copy()
    lower, upper = (bound.copy() for bound in controller.joint_limits())
    for key, value in limits.get("torque", {}).items():
        torque_limits[joints_matching(names, key)] = value
    for key, (low, high) in limits.get("position", {}).items():
        index = joints_matching(names, key)
        lower[index], upper[index] = low, high
    controller.set_torque_limits(torque_limits)
    controller.set_joint_limits(lower, upper)
