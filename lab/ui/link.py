"""The UI's Zenoh link to a lab, on the client core (`lab.client_core.LabLink`, as `LabClient`
is): commands as queries, telemetry/state/events as latest-value channels the render loop drains
(no Python runs on Zenoh's threads), and the labs it can see.

Behind a router several labs may be visible (`lab/<id>/alive`): the link watches one at a time,
the one named at start or else the first seen, and `select` switches to another. Only the render
loop drains the channels and switches; commands may be sent from any thread.
"""

from __future__ import annotations  # zenoh's generic types are not subscriptable at run time

from collections.abc import Callable, Mapping
from typing import Any

import zenoh

from lab.client_core import LabLink, Reply, decode_message, undeclare
from lab.directory import LabDirectory
from lab.protocol import DEFAULT_ENDPOINT, CommandStruct

OPEN_TIMEOUT_S = 60.0  # how long a starting UI waits for the sim process's endpoint
Message = dict[str, Any]


class Link:
    """The UI process's session with its labs (see the module docstring)."""

    def __init__(
        self,
        endpoint: str = DEFAULT_ENDPOINT,
        cancelled: Callable[[], bool] = lambda: False,
        lab_id: str | None = None,
    ) -> None:
        # a UI started beside its sim waits for it (until `cancelled()`); once open, the
        # session reconnects by itself
        self._link = LabLink(endpoint, OPEN_TIMEOUT_S, cancelled=cancelled, role="ui")
        self.connected = False
        self._streams: tuple[zenoh.Subscriber[Any], ...] = ()
        if lab_id is not None:
            self.select(lab_id)

    @property
    def directory(self) -> LabDirectory:
        """Every lab seen: online or not."""
        return self._link.directory

    @property
    def client_id(self) -> str:
        """The id the UI sends with its commands ("ui-<Zenoh id>": the control lock names it)."""
        return self._link.client_id

    @property
    def lab_id(self) -> str | None:
        """The lab watched (None until one is seen, when none was named)."""
        return self._link.lab_id

    def select(self, lab_id: str) -> None:
        """Watch lab `lab_id` from now on (its channels start empty)."""
        undeclare(*self._streams)
        self._link.select(lab_id)
        self._state = self._link.subscribe("state", zenoh.handlers.RingChannel(1))
        self._telemetry = self._link.subscribe("telemetry", zenoh.handlers.RingChannel(64))
        self._events = self._link.subscribe("events", zenoh.handlers.RingChannel(64))
        self._streams = (self._state, self._telemetry, self._events)
        self.connected = self.directory.is_online(lab_id)

    def request(
        self, verb: str, payload: Mapping[str, object] | None = None, timeout: float | None = None
    ) -> Reply:
        """Send one command and wait for its reply; no reply gives {"ok": False, "error": ...}."""
        return self._link.command(verb, payload, timeout)

    def send(self, command: CommandStruct, timeout: float | None = None) -> Reply:
        """Send one typed command (`lab.protocol`'s struct) and wait for its reply."""
        return self._link.send(command, timeout)

    def latest_state(self) -> Message | None:
        """The newest drawing state since the last call, or None."""
        sample = self._state.try_recv() if self._streams else None
        return None if sample is None else decode_message(sample)

    def _drain(self, subscriber: zenoh.Subscriber[Any]) -> list[Message]:
        out = []
        while (sample := subscriber.try_recv()) is not None:
            out.append(decode_message(sample))
        return out

    def telemetry(self) -> list[Message]:
        """Every telemetry message since the last call (at most the channel's last 64)."""
        return self._drain(self._telemetry) if self._streams else []

    def events(self) -> list[Message]:
        """Every event since the last call (at most the channel's last 64)."""
        return self._drain(self._events) if self._streams else []

    def poll_labs(self) -> bool:
        """Take the liveliness changes seen since the last call into `directory`; with no lab
        watched yet, watch the first one online. Whether anything changed."""
        changed = self._link.poll_alive()
        if self.lab_id is None and (first := self.directory.next_online(None)) is not None:
            self.select(first)
            changed = True
        if self.lab_id is not None:
            self.connected = self.directory.is_online(self.lab_id)
        return changed

    def poll_connected(self) -> bool:
        """Whether the watched lab is reachable, after the liveliness changes seen since the
        last call."""
        self.poll_labs()
        return self.connected

    def close(self) -> None:
        """Undeclare the channels, close the link."""
        undeclare(*self._streams)
        self._link.close()
