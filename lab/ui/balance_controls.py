"""The panel's "Balance" folder (Herzog 2016): the momentum law (PD or LQR) and the stance
(both soles, or one lifted), for a biped with flat feet. Both send their command and show the
reply; the server refuses them for other robots, naming why. The current law's gain matrix K_h at
the current contacts is shown from the page's load on (from `info`) and after each law chosen.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
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


GAIN_RATES = ("ṗx", "ṗy", "ṗz", "k̇x", "k̇y", "k̇z")  # rates of linear, angular momentum
GAIN_ERRORS = ("cx", "cy", "cz", "px", "py", "pz", "kx", "ky", "kz")  # Δc, Δh_lin, Δh_ang
NEGLIGIBLE = 1e-3  # of the largest gain: shown as "·"


def _gain_text(k: float, largest: float) -> str:
    if abs(k) < NEGLIGIBLE * largest:
        return "·"
    return f"{k:.0f}" if abs(k) >= 100 else f"{k:.3g}"


def gain_markdown(gain: list[list[float]] | None) -> str:
    """K_h (ḣ_des = −K_h s, Herzog eqs. 22, 24) as a markdown table that fits the panel: a row
    per error (the CoG and the momentum errors), a column per momentum rate, gains below
    NEGLIGIBLE of the largest as "·"; a line saying why when there is none."""
    if gain is None:
        return "K_h: no `momentum` task in the stack (Herzog's presets have it)"
    K = np.asarray(gain, dtype=float)
    largest = float(np.abs(K).max()) if K.size else 0.0
    header = "| K_h | " + " | ".join(GAIN_RATES) + " |"
    rule = "|" + " --- |" * (len(GAIN_RATES) + 1)
    rows = [
        f"| {name} | " + " | ".join(_gain_text(k, largest) for k in column) + " |"
        for name, column in zip(GAIN_ERRORS, K.T, strict=True)
    ]
    return "\n".join([header, rule, *rows])


class BalanceControls:
    """The folder's controls and its K_h table, which shows the current law's gain from every
    `info` (so from the page's load on) and from each `momentum` reply."""

    def __init__(self, app: CommandHost, gui: viser.GuiApi, order: int) -> None:
        with gui.add_folder("Balance (Herzog 2016)", order=order):
            momentum = gui.add_button_group("Momentum", tuple(MOMENTUM_LABELS))
            stance = gui.add_button_group("Stance", tuple(STANCE_LABELS))
            swing = gui.add_button_group("Leg swing", tuple(SWING_LABELS))
            self.note = gui.add_markdown("")  # the last command's reply
            self.gain = gui.add_markdown("")  # K_h of the current law
        self.app = app
        self.controls: list = [momentum, stance, swing]
        momentum.on_click(
            app.guard(
                lambda e: self._send(e, "momentum", {"mode": MOMENTUM_LABELS[e.target.value]})
            )
        )
        stance.on_click(
            app.guard(lambda e: self._send(e, "stance", {"side": STANCE_LABELS[e.target.value]}))
        )
        swing.on_click(
            app.guard(lambda e: self._send(e, "stance", {"swing": SWING_LABELS[e.target.value]}))
        )

    def show_info(self, info: dict) -> None:
        """Show the law and K_h that `info` acknowledges."""
        self._show_gain(info["momentum"])

    def _show_gain(self, momentum: dict) -> None:
        self.gain.content = f"Momentum law: {momentum['mode']}\n\n" + gain_markdown(
            momentum.get("gain")
        )

    def _send(self, event: viser.GuiEvent, verb: str, payload: dict) -> None:
        if event.client is None:
            return
        reply = self.app.send(event.client, verb, payload)
        if reply is not None and reply.get("ok"):
            self.note.content = f"{verb}: {next(iter(payload.values()))}"
            if verb == "momentum":
                self._show_gain(reply["momentum"])
