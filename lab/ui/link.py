"""The UI's Zenoh link to a lab: commands as queries, telemetry/state/events as latest-value
channels the render loop drains (no Python runs on Zenoh's threads), and the labs it can see.

Behind a router several labs may be visible (`lab/<id>/alive`): the link watches one at a time,
the one named at start or else the first seen, and `select` switches to another. Only the render
loop drains the channels and switches; commands may be sent from any thread.
"""

import json
from collections.abc import Callable

import zenoh

from lab.client import client_id, open_session, query
from lab.directory import LabDirectory
from lab.protocol import ALL_LABS_ALIVE, DEFAULT_ENDPOINT, LabKeys

OPEN_TIMEOUT_S = 60.0  # how long a starting UI waits for the sim process's endpoint


class Link:
    """The UI process's session with its labs (see the module docstring)."""

    def __init__(
        self,
        endpoint: str = DEFAULT_ENDPOINT,
        cancelled: Callable[[], bool] = lambda: False,
        lab_id: str | None = None,
    ) -> None:
        self.keys = LabKeys(lab_id) if lab_id is not None else None
        # a UI started beside its sim waits for it (until `cancelled()`); once open, the
        # session reconnects by itself
        self._session = open_session(endpoint, OPEN_TIMEOUT_S, cancelled)
        # Every lab's liveliness token: PUT while it runs, DELETE when it dies or the link breaks.
        self._alive = self._session.liveliness().declare_subscriber(
            ALL_LABS_ALIVE, zenoh.handlers.FifoChannel(256), history=True
        )
        self.directory = LabDirectory()
        self.connected = False
        self._streams: tuple[zenoh.Subscriber, ...] = ()
        self._token: zenoh.LivelinessToken | None = None  # this UI's, at the lab watched
        if self.keys is not None:
            self.select(self.keys.lab_id)

    @property
    def lab_id(self) -> str | None:
        """The lab watched (None until one is seen, when none was named)."""
        return None if self.keys is None else self.keys.lab_id

    def select(self, lab_id: str) -> None:
        """Watch lab `lab_id` from now on (its channels start empty)."""
        keys = LabKeys(lab_id)
        for subscriber in self._streams:
            subscriber.undeclare()
        self._state = self._session.declare_subscriber(keys.state, zenoh.handlers.RingChannel(1))
        self._telemetry = self._session.declare_subscriber(
            keys.telemetry, zenoh.handlers.RingChannel(64)
        )
        self._events = self._session.declare_subscriber(keys.events, zenoh.handlers.RingChannel(64))
        self._streams = (self._state, self._telemetry, self._events)
        if self._token is not None:
            self._token.undeclare()
        # held while the link is up: a control lock this UI holds goes when it vanishes
        self._token = self._session.liveliness().declare_token(
            keys.client(client_id(self._session))
        )
        self.keys = keys
        self.connected = self.directory.is_online(lab_id)

    def request(self, verb: str, payload: dict | None = None, timeout: float | None = None) -> dict:
        """Send one command and wait for its reply; no reply gives {"ok": False, "error": ...}."""
        keys = self.keys
        if keys is None:
            return {"ok": False, "error": f"{verb}: no lab seen yet"}
        return query(self._session, keys, verb, json.dumps(payload or {}), timeout)

    def latest_state(self) -> dict | None:
        sample = self._state.try_recv() if self._streams else None
        return None if sample is None else json.loads(sample.payload.to_bytes())

    def _drain(self, subscriber: zenoh.Subscriber) -> list[dict]:
        out = []
        while (sample := subscriber.try_recv()) is not None:
            out.append(json.loads(sample.payload.to_bytes()))
        return out

    def telemetry(self) -> list[dict]:
        """Every telemetry message since the last call (at most the channel's last 64)."""
        return self._drain(self._telemetry) if self._streams else []

    def events(self) -> list[dict]:
        return self._drain(self._events) if self._streams else []

    def poll_labs(self) -> bool:
        """Take the liveliness changes seen since the last call into `directory`; with no lab
        watched yet, watch the first one online. Whether anything changed."""
        changed = False
        while (sample := self._alive.try_recv()) is not None:
            alive = sample.kind == zenoh.SampleKind.PUT
            changed |= self.directory.seen(str(sample.key_expr), alive)
        if self.keys is None and (first := self.directory.next_online(None)) is not None:
            self.select(first)
            changed = True
        if self.keys is not None:
            self.connected = self.directory.is_online(self.keys.lab_id)
        return changed

    def poll_connected(self) -> bool:
        """Whether the watched lab is reachable, after the liveliness changes seen since the
        last call."""
        self.poll_labs()
        return self.connected

    def close(self) -> None:
        tokens = (self._token,) if self._token is not None else ()
        for sub in (*tokens, self._alive, *self._streams):
            sub.undeclare()
        self._session.close()
