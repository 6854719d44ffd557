"""Velocity joystick: a planar gizmo offset or hotkey taps mapped to a `velocity` command."""

import math
from dataclasses import dataclass

from lab.protocol import VelocityCommand


@dataclass(frozen=True)
class JoystickLimits:
    """Command limits and the gizmo geometry that maps onto them."""

    max_vx: float = 0.6  # m/s
    max_vy: float = 0.4  # m/s
    max_yaw_rate: float = 1.0  # rad/s
    radius: float = 0.3  # m of gizmo travel that gives full speed
    deadzone: float = 0.02  # m of gizmo travel ignored around the centre
    step_fraction: float = 0.25  # one hotkey tap changes a component by this share of its max


def _clamp(x: float, limit: float) -> float:
    return max(-limit, min(limit, x))


def from_offset(dx: float, dy: float, yaw_rate: float, limits: JoystickLimits) -> VelocityCommand:
    """Gizmo offset (dx forward, dy left, metres, in the robot's heading frame) to a command.

    Inside the deadzone the planar velocity is zero; beyond it speed grows linearly and saturates
    at `radius`, keeping the direction of the offset.
    """
    r = math.hypot(dx, dy)
    if r <= limits.deadzone:
        vx = vy = 0.0
    else:
        s = min(1.0, (r - limits.deadzone) / (limits.radius - limits.deadzone)) / r
        vx, vy = dx * s * limits.max_vx, dy * s * limits.max_vy
    return VelocityCommand(vx, vy, _clamp(yaw_rate, limits.max_yaw_rate))


def tap(cmd: VelocityCommand, axis: str, direction: int, limits: JoystickLimits) -> VelocityCommand:
    """One hotkey tap: change `axis` ("vx", "vy" or "yaw_rate") by one step in `direction`."""
    maxima = {"vx": limits.max_vx, "vy": limits.max_vy, "yaw_rate": limits.max_yaw_rate}
    if axis not in maxima or direction not in (-1, 1):
        raise ValueError(f"bad joystick tap: axis {axis!r}, direction {direction!r}")
    step = direction * limits.step_fraction * maxima[axis]
    value = round(_clamp(getattr(cmd, axis) + step, maxima[axis]), 9)
    values = {"vx": cmd.vx, "vy": cmd.vy, "yaw_rate": cmd.yaw_rate, axis: value}
    return VelocityCommand(**values)
