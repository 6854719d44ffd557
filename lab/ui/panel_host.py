"""What a browser's panel and its folders need of the lab app (`PanelHost`): the acknowledged
`info`, sending commands for their browser, reporting, and the robot's heading and pushable
base. The app implements it (tests/ui/test_ui_logic.py checks), so panel and app do not
import each other.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import viser

from lab.protocol import VelocityCommand


class PanelHost(Protocol):
    """What a panel needs of the lab app (see the module docstring)."""

    info: dict | None

    def guard(self, callback: Callable) -> Callable:
        """`callback` with any exception reported in the page instead of raised."""

    def send(self, client: viser.ClientHandle, verb: str, payload: dict) -> dict | None:
        """Send a command for `client` (None when it may not act: it does not hold control,
        or another client holds the lab's control lock)."""

    def take_control(self, client_id: int) -> None:
        """Browser `client_id` takes control (and the lab's lock, if another client's)."""

    def switch_lab(self, client: viser.ClientHandle, lab_id: str) -> None:
        """Watch and drive lab `lab_id` (for a browser holding control)."""

    def set_velocity(self, client: viser.ClientHandle, cmd: VelocityCommand) -> None:
        """Send `cmd` and resend it until another replaces it (the lab's deadman)."""

    def report(
        self,
        level: str,
        text: str,
        client: viser.ClientHandle | None = None,
        category: str | None = None,
    ) -> None:
        """A line in the event log (in `category`, lab/ui/event_log.py), popped up in
        `client`'s browser when given."""

    def notify_error(self, client: viser.ClientHandle, verb: str, error: str) -> None:
        """`verb` was not applied because of `error`: logged and popped up in `client`."""

    def base_yaw(self) -> float:
        """The robot's heading (rad about z), from the newest telemetry."""

    def base_body(self) -> str:
        """The floating base link, the body the push buttons push."""
