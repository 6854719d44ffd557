"""Session: one robot in one MuJoCo world under the whole-body controller, one tick at a time.

The same object runs headless (tests, scenarios, benchmarks: as fast as the CPU allows) and
inside the realtime sim process (which adds the schedule and Zenoh around it). Commands arrive as
(verb, JSON payload), are validated into their lab.protocol struct by `parse_command`, and are
applied between ticks (`_apply`: one case per struct); a rejected command changes nothing and the
reply names the problem. What a session publishes (telemetry, the drawing state) is built in
`telemetry.py`.

`Session` is built in layers, one job a module: what it is built from and builds
(session_parts.py: `SessionConfig`, `SessionParts`, `build_parts`), its set-up, reset, behaviour
and events (session_base.py), the tick and its faults (session_tick.py), the commands and `info`
(session_commands.py), and here the reports (telemetry, drawing state, warnings).
"""

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from lab.world.session_commands import SessionCommands
from lab.world.session_parts import SessionConfig
from lab.world.telemetry import state_message, telemetry_in_two, telemetry_message

__all__ = ["Session", "SessionConfig"]


# s of sim time a warning of the controller (e.g. nullspace's ActiveSetCapWarning) stays in
# telemetry's `controller_warnings` after the last tick that raised it
WARNING_HOLD_S = 0.5


class Session(SessionCommands):
    """One robot in one MuJoCo world under the whole-body controller (module docstring),
    built as `SessionBase` says."""

    def telemetry(self) -> dict:
        """Everything the UI plots and the tests check, JSON-ready (see docs/protocol.md)."""
        return telemetry_message(self)

    def telemetry_in_two(self) -> tuple[dict, Callable[[], None]]:
        """`telemetry` in two steps, for two ticks of the realtime loop: the message with this
        tick's state now, `finish` fills in the rest later (`telemetry.telemetry_in_two`)."""
        return telemetry_in_two(self)

    def recent_warnings(self) -> list[dict]:
        """The controller's warnings (e.g. nullspace's active-set cap) raised within the last
        WARNING_HOLD_S of sim time, one entry per kind (telemetry's `controller_warnings`)."""
        return [
            {"kind": kind, "message": w.message, "t": w.t, "ticks": w.ticks}
            for kind, w in self._warnings.items()
            if self.time - w.t <= WARNING_HOLD_S
        ]

    def drawing_state(self) -> dict:
        """What the UI needs to draw the robot (`lab/state`)."""
        return state_message(self)

    def base_orientation_error(self) -> float:
        """Angle (rad) between the base and its reference orientation."""
        R_ref = self.controller.references.base_rotation
        return float(np.linalg.norm(pin.log3(R_ref.T @ self.model.base_rotation)))
