"""A small Python client of the lab server (docs/protocol.md), for scripts, tests and teleop.

with LabClient() as lab:
    print(lab.command("info"))
    lab.command("push", body="base", force=[0, 80, 0], duration=0.2)
    print(lab.latest_telemetry()["base"]["linear_velocity"])

Behind a router with several labs, name one: `LabClient("tcp/router:7447", lab_id="hostA-anymal")`.
"""

from __future__ import annotations  # zenoh's generic types are not subscriptable at run time

import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

from lab.client_core import (
    Channel,
    LabLink,
    LabNotFound,
    Reply,
    decode_message,
    find_labs,
    only_lab,
    undeclare,
)
from lab.protocol import DEFAULT_ENDPOINT, CommandStruct

# Messages a client keeps between two reads, per kind: `wait_telemetry` looks at every telemetry
# message that arrives while it waits (up to 2.5 s of them at 100 Hz between two reads), so a
# brief event, a push of 0.2 s, is seen however late it runs; of the state (60 Hz, every frame of
# the robot) only the newest is wanted.
BACKLOG: dict[Channel, int] = {"telemetry": 256, "state": 1}
Message = dict[str, Any]

__all__ = ["LabClient", "LabNotFound"]


class LabClient:
    """One Zenoh client session to one lab (sim process); close it (or use `with`).

    `lab_id` names the lab to talk to; without it the client looks for the labs behind
    `endpoint` for up to `connect_timeout` s and takes the only one; several raise `LabNotFound`
    naming them, unless `first` (then the first by id). `labs()` lists every lab seen, `select`
    switches to another. `role` prefixes the client id (`lab teleop`: "teleop"), which the
    control lock's refusals name. Built on the client core (`lab.client_core.LabLink`), as the
    UI is."""

    def __init__(
        self,
        endpoint: str = DEFAULT_ENDPOINT,
        connect_timeout: float = 5.0,
        lab_id: str | None = None,
        first: bool = False,
        role: str = "",
    ) -> None:
        self.endpoint = endpoint
        self._lock = threading.Lock()
        self._connected = threading.Event()
        self._latest: dict[Channel, zenoh.Subscriber[Any]] = {}
        self._last: dict[Channel, Message | None] = {}
        self._callbacks: list[tuple[Channel, Callable[[Message], None], zenoh.Subscriber[Any]]] = []
        self._link = LabLink(endpoint, connect_timeout, self._on_alive, role=role)
        try:
            if lab_id is None:
                found = find_labs(self._link.session, connect_timeout)
                lab_id = found[0] if first and found else only_lab(found, endpoint)
            self.select(lab_id)
        except BaseException:
            self.close()
            raise

    @property
    def lab_id(self) -> str:
        """The lab this client talks to."""
        lab_id = self._link.lab_id
        assert lab_id is not None
        return lab_id

    @property
    def session(self) -> zenoh.Session:
        """The Zenoh session (raw queries with their own attachment, as the tests send)."""
        return self._link.session

    @property
    def client_id(self) -> str:
        """The id this client sends with each command (the control lock names its holder so)."""
        return self._link.client_id

    def labs(self) -> dict[str, bool]:
        """Every lab seen since the client started, sorted by id: whether it is online now."""
        return self._link.directory.labs()

    def select(self, lab_id: str) -> None:
        """Talk to lab `lab_id` from now on: commands, telemetry, state, events, `connected`
        (callbacks given to `subscribe_*` follow). Raises LabIdError for an id that cannot be
        one."""
        with self._lock:
            old = [*self._latest.values(), *(sub for _, _, sub in self._callbacks)]
            callbacks = [(kind, callback) for kind, callback, _ in self._callbacks]
            self._link.select(lab_id)
            if self._link.directory.is_online(lab_id):
                self._connected.set()
            else:
                self._connected.clear()
        undeclare(*old)
        latest = {
            kind: self._link.subscribe(kind, zenoh.handlers.RingChannel(capacity))
            for kind, capacity in BACKLOG.items()
        }
        declared = [(kind, cb, self._declare_callback(kind, cb)) for kind, cb in callbacks]
        with self._lock:
            self._latest, self._last, self._callbacks = latest, dict.fromkeys(latest), declared

    @property
    def connected(self) -> bool:
        """Whether the lab is reachable now: its liveliness token is seen (it vanishes within
        about a second of the process dying or the link to it breaking)."""
        return self._connected.is_set()

    def wait_connected(self, connected: bool = True, timeout: float = 5.0) -> bool:
        """Wait until `connected` is what the link is; True if it became so within `timeout`."""
        end = time.monotonic() + timeout
        while self.connected != connected:
            if time.monotonic() > end:
                return False
            time.sleep(0.01)
        return True

    def _on_alive(self, about_selected: bool, alive: bool) -> None:
        """A lab's liveliness changed (on a Zenoh thread; the link's directory has it)."""
        with self._lock:
            if not about_selected:
                return
            if alive:
                self._connected.set()
            else:
                self._connected.clear()

    def command(self, verb: str, timeout: float | None = None, **fields: object) -> Reply:
        """Send `verb` with `fields` as its JSON payload; return the server's reply."""
        return self._link.command(verb, fields, timeout)

    def send(self, command: CommandStruct, timeout: float | None = None) -> Reply:
        """Send one typed command (`lab.protocol`'s struct); return the server's reply."""
        return self._link.send(command, timeout)

    def request(self, verb: str, payload: str | bytes, timeout: float | None = None) -> Reply:
        """Send a raw payload to `lab/<id>/cmd/<verb>`; see `lab.client_core.query`."""
        return self._link.request(verb, payload, timeout)

    def latest_telemetry(self) -> Message | None:
        """The newest telemetry message received so far (None before the first)."""
        return self._newest("telemetry")

    def latest_state(self) -> Message | None:
        """The newest `lab/<id>/state` message received so far (None before the first)."""
        return self._newest("state")

    def wait_telemetry(
        self,
        predicate: Callable[[Message], bool] = lambda _: True,
        timeout: float = 5.0,
        since_last_read: bool = False,
    ) -> Message:
        """The first telemetry message for which `predicate` holds: the newest one received
        before the call (with `since_last_read`, every one received since the last read, at most
        BACKLOG's), then every one after it (a brief event is not missed however late this
        thread runs); raise TimeoutError with the last message."""
        end = time.monotonic() + timeout
        messages = self._fresh("telemetry", newest_only=not since_last_read)
        last = None
        while time.monotonic() < end:
            for message in messages:
                last = message
                if predicate(message):
                    return message
            time.sleep(0.002)
            messages = self._fresh("telemetry")
        raise TimeoutError(f"telemetry condition not met within {timeout:g} s; last: {last}")

    def subscribe_telemetry(self, callback: Callable[[Message], None]) -> None:
        """Call `callback(message)` for every telemetry message (on a Zenoh thread)."""
        self._subscribe("telemetry", callback)

    def subscribe_state(self, callback: Callable[[Message], None]) -> None:
        """Call `callback(message)` for every `lab/<id>/state` message (on a Zenoh thread)."""
        self._subscribe("state", callback)

    def subscribe_events(self, callback: Callable[[Message], None]) -> None:
        """Call `callback(event)` for every `lab/<id>/events` message (on a Zenoh thread)."""
        self._subscribe("events", callback)

    def close(self) -> None:
        """Undeclare every subscriber, close the link."""
        undeclare(*(entry[-1] for entry in self._callbacks), *self._latest.values())
        self._callbacks.clear()
        self._latest.clear()
        self._link.close()

    def __enter__(self) -> LabClient:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def _declare_callback(
        self, kind: Channel, callback: Callable[[Message], None]
    ) -> zenoh.Subscriber[Any]:
        def on_sample(sample: zenoh.Sample) -> None:
            callback(decode_message(sample))

        return self._link.subscribe(kind, on_sample)

    def _subscribe(self, kind: Channel, callback: Callable[[Message], None]) -> None:
        subscriber = self._declare_callback(kind, callback)
        with self._lock:
            self._callbacks.append((kind, callback, subscriber))

    def _fresh(self, kind: Channel, newest_only: bool = False) -> list[Message]:
        """The messages received since the last read (at most BACKLOG[kind]), oldest first;
        with `newest_only`, the newest alone (the others are dropped unparsed)."""
        with self._lock:
            subscriber = self._latest[kind]
        samples = []
        while (sample := subscriber.try_recv()) is not None:
            samples.append(sample)
        if newest_only:
            samples = samples[-1:]
        messages = [decode_message(sample) for sample in samples]
        if messages:
            with self._lock:
                if self._latest.get(kind) is subscriber:  # not from a lab switched away from
                    self._last[kind] = messages[-1]
        return messages

    def _newest(self, kind: Channel) -> Message | None:
        self._fresh(kind, newest_only=True)
        with self._lock:
            return self._last[kind]
