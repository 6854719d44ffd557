"""A small Python client of the lab server (docs/protocol.md), for scripts, tests and teleop.

with LabClient() as lab:
    print(lab.command("info"))
    lab.command("push", body="base", force=[0, 80, 0], duration=0.2)
    print(lab.latest_telemetry()["base"]["linear_velocity"])
"""

import json
import threading
import time
from collections.abc import Callable

import zenoh

from lab.protocol import (
    CMD_PREFIX,
    DEFAULT_ENDPOINT,
    KEY_ALIVE,
    KEY_EVENTS,
    KEY_STATE,
    KEY_TELEMETRY,
)
from lab.server.transport import client_config

COMMAND_TIMEOUT_S = 2.0
SLOW_COMMAND_TIMEOUT_S = 20.0  # robot / scene switches rebuild the session
SLOW_VERBS = ("robot", "scene")


class LabClient:
    """One Zenoh client session to the lab server; close it (or use `with`)."""

    def __init__(self, endpoint: str = DEFAULT_ENDPOINT, connect_timeout: float = 5.0) -> None:
        self.endpoint = endpoint
        self._session = open_session(endpoint, connect_timeout)
        self._latest: dict[str, zenoh.Subscriber] = {
            key: self._session.declare_subscriber(key, zenoh.handlers.RingChannel(1))
            for key in (KEY_TELEMETRY, KEY_STATE)
        }
        self._last: dict[str, dict | None] = {KEY_TELEMETRY: None, KEY_STATE: None}
        self._callbacks: list[zenoh.Subscriber] = []
        self._lock = threading.Lock()
        self._connected = threading.Event()
        self._alive = self._session.liveliness().declare_subscriber(
            KEY_ALIVE, self._on_alive, history=True
        )

    @property
    def connected(self) -> bool:
        """Whether the sim process is reachable now: its liveliness token is seen (it vanishes
        within about a second of the process dying or the link to it breaking)."""
        return self._connected.is_set()

    def wait_connected(self, connected: bool = True, timeout: float = 5.0) -> bool:
        """Wait until `connected` is what the link is; True if it became so within `timeout`."""
        end = time.monotonic() + timeout
        while self.connected != connected:
            if time.monotonic() > end:
                return False
            time.sleep(0.01)
        return True

    def _on_alive(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self._connected.set()
        else:
            self._connected.clear()

    def command(self, verb: str, timeout: float | None = None, **fields: object) -> dict:
        """Send `verb` with `fields` as its JSON payload; return the server's reply."""
        return self.request(verb, json.dumps(fields), timeout)

    def request(self, verb: str, payload: str | bytes, timeout: float | None = None) -> dict:
        """Send a raw payload to `lab/cmd/<verb>`; see `query`."""
        return query(self._session, verb, payload, timeout)

    def latest_telemetry(self) -> dict | None:
        """The newest telemetry message received so far (None before the first)."""
        return self._newest(KEY_TELEMETRY)

    def latest_state(self) -> dict | None:
        """The newest `lab/state` message received so far (None before the first)."""
        return self._newest(KEY_STATE)

    def wait_telemetry(
        self, predicate: Callable[[dict], bool] = lambda _: True, timeout: float = 5.0
    ) -> dict:
        """Poll telemetry until `predicate` holds; raise TimeoutError with the last message."""
        end = time.monotonic() + timeout
        last = None
        while time.monotonic() < end:
            message = self._fresh(KEY_TELEMETRY)
            if message is not None:
                last = message
                if predicate(message):
                    return message
            time.sleep(0.002)
        raise TimeoutError(f"telemetry condition not met within {timeout:g} s; last: {last}")

    def subscribe_telemetry(self, callback: Callable[[dict], None]) -> None:
        """Call `callback(message)` for every telemetry message (on a Zenoh thread)."""
        self._subscribe(KEY_TELEMETRY, callback)

    def subscribe_state(self, callback: Callable[[dict], None]) -> None:
        """Call `callback(message)` for every `lab/state` message (on a Zenoh thread)."""
        self._subscribe(KEY_STATE, callback)

    def subscribe_events(self, callback: Callable[[dict], None]) -> None:
        """Call `callback(event)` for every `lab/events` message (on a Zenoh thread)."""
        self._subscribe(KEY_EVENTS, callback)

    def close(self) -> None:
        for subscriber in [self._alive, *self._callbacks, *self._latest.values()]:
            subscriber.undeclare()
        self._callbacks.clear()
        self._session.close()

    def __enter__(self) -> "LabClient":
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def _subscribe(self, key: str, callback: Callable[[dict], None]) -> None:
        def on_sample(sample: zenoh.Sample) -> None:
            callback(json.loads(sample.payload.to_bytes()))

        self._callbacks.append(self._session.declare_subscriber(key, on_sample))

    def _fresh(self, key: str) -> dict | None:
        """A message received since the last read, or None."""
        sample = self._latest[key].try_recv()
        if sample is None:
            return None
        message = json.loads(sample.payload.to_bytes())
        with self._lock:
            self._last[key] = message
        return message

    def _newest(self, key: str) -> dict | None:
        self._fresh(key)
        with self._lock:
            return self._last[key]


def query(
    session: zenoh.Session, verb: str, payload: str | bytes, timeout: float | None = None
) -> dict:
    """Send a raw payload to `lab/cmd/<verb>` and return the server's reply. A missing reply
    becomes {"ok": false, "error": "no reply ..."} so callers handle one shape."""
    if timeout is None:
        timeout = SLOW_COMMAND_TIMEOUT_S if verb in SLOW_VERBS else COMMAND_TIMEOUT_S
    no_reply = {"ok": False, "error": f"{verb}: no reply within {timeout:g} s"}
    for reply in session.get(CMD_PREFIX + verb, payload=payload, timeout=timeout):
        if reply.ok is None:  # Zenoh's own error, e.g. "Timeout" from an unanswered query
            error = reply.err.payload.to_string()
            return no_reply if error == "Timeout" else {"ok": False, "error": f"{verb}: {error}"}
        try:
            return json.loads(reply.ok.payload.to_bytes())
        except ValueError:
            return {"ok": False, "error": f"{verb}: the reply is not JSON"}
    return no_reply


def open_session(
    endpoint: str, timeout: float, cancelled: Callable[[], bool] = lambda: False
) -> zenoh.Session:
    """Open a client session to `endpoint`, retrying for `timeout` s (or until `cancelled()`)
    while the server is still starting (a Zenoh client cannot open a session with nothing to
    connect to)."""
    end = time.monotonic() + timeout
    while True:
        try:
            return zenoh.open(client_config(endpoint))
        except zenoh.ZError:
            if time.monotonic() > end or cancelled():
                raise
            time.sleep(0.05)
