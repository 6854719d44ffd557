"""The panel's "Lab" dropdown: the labs the UI sees behind its Zenoh endpoint (a router may join
several, docs/protocol.md), which one the page shows and drives, and which went offline.

A lab whose sim process stops (or whose link breaks) stays in the list marked "offline" and
loses the mark when it returns. Choosing another lab asks the app to switch (`LabHost`); the
dropdown is one of the panel's controls, so a read-only browser cannot switch everybody's view.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import viser

OFFLINE = " (offline)"


class LabHost(Protocol):
    """What the dropdown needs of the lab app."""

    def guard(self, callback: Callable) -> Callable:
        """`callback` with any exception reported in the page instead of raised."""

    def switch_lab(self, client: viser.ClientHandle, lab_id: str) -> None:
        """Show and drive lab `lab_id` from now on (refused for a read-only browser)."""


def lab_label(lab_id: str, online: bool) -> str:
    """The dropdown's option for a lab."""
    return lab_id if online else lab_id + OFFLINE


def lab_of(label: str) -> str:
    """The lab id of a dropdown option."""
    return label.removesuffix(OFFLINE)


def labs_note(labs: dict[str, bool]) -> str:
    """One line under the dropdown: how many labs are seen, and which are offline."""
    offline = [lab_id for lab_id, online in labs.items() if not online]
    text = f"{len(labs) - len(offline)} of {len(labs)} labs online"
    return text + (f"; offline: {', '.join(offline)}" if offline else "")


class LabPicker:
    """The dropdown and its note in one browser's panel."""

    def __init__(self, app: LabHost, client: viser.ClientHandle, order: float) -> None:
        self.app, self.client = app, client
        gui = client.gui
        self.dropdown = gui.add_dropdown(
            "Lab", ("…",), order=order, hint="the lab (sim process) this page shows and drives"
        )
        self.note = gui.add_markdown("", order=order + 0.01)
        self._shown: tuple | None = None
        self.dropdown.on_update(app.guard(self._chosen))

    def show(self, labs: dict[str, bool], watched: str | None) -> None:
        """List `labs` (id -> online) with `watched` chosen; nothing is sent."""
        if watched is not None and watched not in labs:  # named at start, not seen yet
            labs = {**labs, watched: False}
        if (shown := (tuple(labs.items()), watched)) == self._shown:
            return
        self._shown = shown
        options = tuple(lab_label(lab_id, online) for lab_id, online in labs.items())
        self.dropdown.options = options or ("…",)  # assignments call `_chosen` with no client
        if watched is not None:
            self.dropdown.value = lab_label(watched, labs[watched])
        self.note.content = labs_note(labs) if labs else "no lab seen yet"

    def _chosen(self, event: viser.GuiEvent) -> None:
        if event.client_id is not None and self.dropdown.value != "…":
            self.app.switch_lab(self.client, lab_of(self.dropdown.value))


def add_lab_picker(app: LabHost, client: viser.ClientHandle, order: float) -> LabPicker:
    """Add the dropdown to `client`'s panel; the app calls its `show` as labs come and go."""
    return LabPicker(app, client, order)
