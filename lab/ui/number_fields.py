"""The panel's number fields: when each was last typed in, a note under a field, and a field
made to show exactly the number sent.

Viser sends a typed number at most every 50 ms and a click in that window replaces the pending
number (its throttle keeps only the newest message): a click this soon after a typed update may
carry a number the box no longer shows, so it is refused with a message instead (`TypedAt`).
"""

import time

import viser

from lab.ui.panel_host import PanelHost

TYPING_SETTLE_S = 0.4


class TypedAt:
    """When each number field (by label) was last changed in the browser."""

    def __init__(self) -> None:
        self._at: dict[str, float] = {}

    def typed(self, label: str) -> None:
        self._at[label] = time.monotonic()

    def busy(self, *labels: str) -> list[str]:
        """Those of `labels` changed less than TYPING_SETTLE_S ago."""
        now = time.monotonic()
        return [k for k in labels if now - self._at.get(k, -1e9) < TYPING_SETTLE_S]


def busy_note(busy: list[str]) -> str:
    """Why a click was refused: the fields `busy` changed too recently."""
    return (
        f"{', '.join(busy)} changed less than {TYPING_SETTLE_S:g} s ago: the typed number may "
        "not have reached the lab yet. Nothing sent: check the box and press again"
    )


def note(
    host: PanelHost,
    client: viser.ClientHandle,
    where: viser.GuiMarkdownHandle,
    level: str,
    text: str,
    category: str | None = None,
) -> None:
    """A message under the widgets it is about, in the event log (in `category`), and popped
    up in `client` unless it is good news."""
    where.content = f"{'⚠' if level != 'info' else '✔'} {text}"
    host.report(level, text, client if level != "info" else None, category)


def show_value(handle: viser.GuiInputHandle, value: float | str) -> None:
    """Make the browser show `value` in `handle` even if this process already holds it."""
    # viser skips an assignment of the value it holds: assign another one first
    handle.value = value + " " if isinstance(value, str) else value + 1.0
    handle.value = value
