"""The UI's Zenoh link to the sim process: commands as queries, telemetry/state/events as
latest-value channels the render loop drains (no Python runs on Zenoh's threads)."""

import json
from collections.abc import Callable

import zenoh

from lab.client import open_session, query
from lab.protocol import DEFAULT_ENDPOINT, KEY_ALIVE, KEY_EVENTS, KEY_STATE, KEY_TELEMETRY

OPEN_TIMEOUT_S = 60.0  # how long a starting UI waits for the sim process's endpoint


class Link:
    """The UI process's session with the sim process (see the module docstring)."""

    def __init__(
        self, endpoint: str = DEFAULT_ENDPOINT, cancelled: Callable[[], bool] = lambda: False
    ) -> None:
        # a UI started beside its sim waits for it (until `cancelled()`); once open, the
        # session reconnects by itself
        self._session = open_session(endpoint, OPEN_TIMEOUT_S, cancelled)
        # The sim's liveliness token: PUT while it runs, DELETE when it dies or the link breaks.
        self._alive = self._session.liveliness().declare_subscriber(
            KEY_ALIVE, zenoh.handlers.FifoChannel(16), history=True
        )
        self.connected = False
        self._state = self._session.declare_subscriber(KEY_STATE, zenoh.handlers.RingChannel(1))
        self._telemetry = self._session.declare_subscriber(
            KEY_TELEMETRY, zenoh.handlers.RingChannel(64)
        )
        self._events = self._session.declare_subscriber(KEY_EVENTS, zenoh.handlers.RingChannel(64))

    def request(self, verb: str, payload: dict | None = None, timeout: float | None = None) -> dict:
        """Send one command and wait for its reply; no reply gives {"ok": False, "error": ...}."""
        return query(self._session, verb, json.dumps(payload or {}), timeout)

    def latest_state(self) -> dict | None:
        sample = self._state.try_recv()
        return None if sample is None else json.loads(sample.payload.to_bytes())

    def _drain(self, subscriber: zenoh.Subscriber) -> list[dict]:
        out = []
        while (sample := subscriber.try_recv()) is not None:
            out.append(json.loads(sample.payload.to_bytes()))
        return out

    def telemetry(self) -> list[dict]:
        """Every telemetry message since the last call (at most the channel's last 64)."""
        return self._drain(self._telemetry)

    def events(self) -> list[dict]:
        return self._drain(self._events)

    def poll_connected(self) -> bool:
        """Whether the sim process is reachable, after the liveliness changes seen since the
        last call."""
        while (sample := self._alive.try_recv()) is not None:
            self.connected = sample.kind == zenoh.SampleKind.PUT
        return self.connected

    def close(self) -> None:
        for sub in (self._alive, self._state, self._telemetry, self._events):
            sub.undeclare()
        self._session.close()
