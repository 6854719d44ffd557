"""The page's hold on the lab's control lock (docs/protocol.md "The control lock", docs/ui.md).

The lab has one control lock between its clients, and the UI process is one client of it (its
client id `ui-<Zenoh id>`). Between its own browsers the page has its ownership
(`ownership.py`); towards the lab it takes the lock when a browser holding control acts (sends a
command that changes the world) or presses *Take control*, keeps it while a browser holds
control, and releases it when none does, on a switch to another lab, and when it exits. Merely
opening the page takes nothing, so a script or a terminal teleop may drive a lab that a page
only watches. Telemetry and `info` carry the holder (`control.holder`): while another client
holds it, the page reads only and says who holds it.

Bookkeeping over a `request(verb)` callable (the UI's link); one take or release at a time.
"""

import threading
from collections.abc import Callable, Mapping
from typing import Any

Reply = Mapping[str, Any]


class LabLock:
    """Who holds the lab's lock as the page last saw it, and the page's take and release."""

    def __init__(self, me: str, request: Callable[[str], Reply]) -> None:
        self.me = me  # the UI's client id
        self.holder: str | None = None  # as last seen (telemetry, `info`, a take or release)
        self._request = request
        self._asking = threading.Lock()  # viser's callback threads and the render loop ask

    def seen(self, message: Mapping[str, Any]) -> bool:
        """Take the holder a telemetry message or `info` reply reports (none reported: a lab
        without a lock, such as a recording); whether `other` changed (what the page shows: a
        message built before the page's own take still says "free")."""
        control = message.get("control")
        before = self.other()
        self.holder = None if control is None else control.get("holder")
        return self.other() != before

    def other(self) -> str | None:
        """The client holding the lock when it is not this page (None: free, or the page's)."""
        holder = self.holder
        return None if holder in (None, self.me) else holder

    def acquire(self) -> str | None:
        """Hold the lock (a `take` unless the page holds it already): None when it does, else
        the lab's refusal without its verb, naming the holder ("client teleop-… holds the
        control lock")."""
        with self._asking:
            if self.holder == self.me:
                return None
            reply = self._request("take")
            if reply.get("ok"):
                self.holder = self.me
                return None
        return str(reply.get("error", "refused")).removeprefix("take: ")

    def release(self) -> None:
        """Release the lock if the page holds it (a lab that has gone releases it itself)."""
        with self._asking:
            if self.holder == self.me:
                self.holder = None
                self._request("release")

    def forget(self) -> None:
        """Another lab is watched from now on: its holder is not known yet."""
        self.holder = None
