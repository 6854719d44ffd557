"""The velocity deadman: a velocity command the client stops refreshing (a lost link, a
crashed teleop) expires, and the robot is slowed to a stop instead of walking on."""

from lab.protocol import VelocityCommand

DEADMAN_TIMEOUT_S = 0.5  # a velocity command expires this long after its last refresh...
DEADMAN_RAMP_S = 0.5  # ...and then ramps linearly to zero over this long
DEADMAN_UPDATE_S = 0.01  # how often the ramp sends a new velocity to the session


class Deadman:
    """A velocity command expires `DEADMAN_TIMEOUT_S` after its last refresh, then ramps
    linearly to zero over `DEADMAN_RAMP_S`."""

    def __init__(self) -> None:
        self._command = VelocityCommand()
        self._refreshed = 0.0
        self._last_update = 0.0
        self._active = False

    def refresh(self, command: VelocityCommand, now: float) -> None:
        self._command = command
        self._refreshed = now
        self._active = command != VelocityCommand()

    def update(self, now: float) -> VelocityCommand | None:
        """The decayed command to send now, or None when nothing needs to change."""
        age = now - self._refreshed
        if not self._active or age <= DEADMAN_TIMEOUT_S:
            return None
        scale = max(0.0, 1.0 - (age - DEADMAN_TIMEOUT_S) / DEADMAN_RAMP_S)
        if scale > 0.0 and now - self._last_update < DEADMAN_UPDATE_S:
            return None
        self._last_update = now
        self._active = scale > 0.0
        c = self._command
        return VelocityCommand(c.vx * scale, c.vy * scale, c.yaw_rate * scale)
