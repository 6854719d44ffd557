"""The panel's "Balance" folder (Herzog 2016): the momentum law (PD or LQR) and the stance
(both soles, or one lifted), for a biped with flat feet. Both send their command and show the
reply; the server refuses them for other robots, naming why.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import viser

MOMENTUM_LABELS = {"PD": "pd", "LQR": "lqr", "LQR Talos": "lqr_talos"}
STANCE_LABELS = {"Both feet": "double", "On left": "left", "On right": "right"}
SWING_LABELS = {"Swing leg 0.25 Hz": 0.25, "Stop swing": 0.0}  # Herzog §5.4, Fig. 11


class CommandHost(Protocol):
    """What the folder needs of the lab app (a part of panel.PanelHost)."""

    def guard(self, callback: Callable) -> Callable:
        """`callback` with any exception reported in the page instead of raised."""

    def send(self, client: viser.ClientHandle, verb: str, payload: dict) -> dict | None:
        """Send a command for `client` (None when it does not hold control)."""


def add_balance_controls(app: CommandHost, client: viser.ClientHandle, order: int) -> list:
    """Add the folder to `client`'s panel; returns its controls (greyed out while read-only)."""
    gui = client.gui
    with gui.add_folder("Balance (Herzog 2016)", order=order):
        momentum = gui.add_button_group("Momentum", tuple(MOMENTUM_LABELS))
        stance = gui.add_button_group("Stance", tuple(STANCE_LABELS))
        swing = gui.add_button_group("Leg swing", tuple(SWING_LABELS))
        note = gui.add_markdown("")

    def send(verb: str, payload: dict) -> None:
        reply = app.send(client, verb, payload)
        if reply is not None and reply.get("ok"):
            note.content = f"{verb}: {next(iter(payload.values()))}"

    momentum.on_click(
        app.guard(lambda e: send("momentum", {"mode": MOMENTUM_LABELS[e.target.value]}))
    )
    stance.on_click(app.guard(lambda e: send("stance", {"side": STANCE_LABELS[e.target.value]})))
    swing.on_click(app.guard(lambda e: send("stance", {"swing": SWING_LABELS[e.target.value]})))
    return [momentum, stance, swing]
