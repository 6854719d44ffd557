"""The UI's Zenoh link to the sim process: commands as queries, telemetry/state/events as
latest-value channels the render loop drains (no Python runs on Zenoh's threads)."""

import json

import zenoh

from lab.server.transport import (
    CMD_PREFIX,
    DEFAULT_ENDPOINT,
    KEY_EVENTS,
    KEY_STATE,
    KEY_TELEMETRY,
    client_config,
)

SLOW_VERBS = ("robot", "scene")  # rebuild the session: allow a long reply time


class Link:
    def __init__(self, endpoint: str = DEFAULT_ENDPOINT) -> None:
        self._session = zenoh.open(client_config(endpoint))
        self._state = self._session.declare_subscriber(KEY_STATE, zenoh.handlers.RingChannel(1))
        self._telemetry = self._session.declare_subscriber(
            KEY_TELEMETRY, zenoh.handlers.RingChannel(64)
        )
        self._events = self._session.declare_subscriber(KEY_EVENTS, zenoh.handlers.RingChannel(64))

    def request(self, verb: str, payload: dict | None = None, timeout: float | None = None) -> dict:
        """Send one command and wait for its reply; no reply gives {"ok": False, "error": ...}."""
        if timeout is None:
            timeout = 15.0 if verb in SLOW_VERBS else 2.0
        replies = self._session.get(
            CMD_PREFIX + verb, payload=json.dumps(payload or {}), timeout=timeout
        )
        for reply in replies:
            if reply.ok is None:
                return {"ok": False, "error": f"{verb}: error reply from Zenoh"}
            try:
                return json.loads(reply.ok.payload.to_bytes())
            except ValueError:
                return {"ok": False, "error": f"{verb}: reply is not JSON"}
        return {"ok": False, "error": f"{verb}: no reply from the lab server within {timeout:g} s"}

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

    def close(self) -> None:
        for sub in (self._state, self._telemetry, self._events):
            sub.undeclare()
        self._session.close()
