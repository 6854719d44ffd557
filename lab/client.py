"""A small Python client of the lab server (docs/protocol.md), for scripts, tests and teleop.

with LabClient() as lab:
    print(lab.command("info"))
    lab.command("push", body="base", force=[0, 80, 0], duration=0.2)
    print(lab.latest_telemetry()["base"]["linear_velocity"])

Behind a router with several labs, name one: `LabClient("tcp/router:7447", lab_id="hostA-anymal")`.
"""

import json
import socket
import threading
import time
from collections.abc import Callable

import zenoh

from lab.directory import LabDirectory
from lab.protocol import ALL_LABS_ALIVE, DEFAULT_ENDPOINT, LabKeys, lab_id_of
from lab.server.access import ENV_CONFIG, ENV_PASSWORD, ENV_USER, credentials_from_env
from lab.server.transport import client_config

COMMAND_TIMEOUT_S = 2.0
# robot / scene switches rebuild the session; `floor` replies after measuring (up to 10 s)
SLOW_COMMAND_TIMEOUT_S = 20.0
SLOW_VERBS = ("robot", "scene", "floor")
# A query that ends with no reply before this fraction of its timeout was closed, not timed out.
TIMED_OUT_FRACTION = 0.9
PROBE_TIMEOUT_S = 2.0  # a TCP connection that tells "nothing there" from "credentials refused"
# Messages a client keeps between two reads, per kind: `wait_telemetry` looks at every telemetry
# message that arrives while it waits (up to 2.5 s of them at 100 Hz between two reads), so a
# brief event, a push of 0.2 s, is seen however late it runs; of the state (60 Hz, every frame of
# the robot) only the newest is wanted.
BACKLOG = {"telemetry": 256, "state": 1}


class LabNotFound(LookupError):
    """No lab, or several and none chosen, behind a client's endpoint."""


class LabClient:
    """One Zenoh client session to one lab (sim process); close it (or use `with`).

    `lab_id` names the lab to talk to; without it the client looks for the labs behind
    `endpoint` for up to `connect_timeout` s and takes the only one; several raise `LabNotFound`
    naming them, unless `first` (then the first by id). `labs()` lists every lab seen, `select`
    switches to another."""

    def __init__(
        self,
        endpoint: str = DEFAULT_ENDPOINT,
        connect_timeout: float = 5.0,
        lab_id: str | None = None,
        first: bool = False,
    ) -> None:
        self.endpoint = endpoint
        self._session = open_session(endpoint, connect_timeout)
        self._lock = threading.Lock()
        self._connected = threading.Event()
        self._directory = LabDirectory()
        self._keys: LabKeys | None = None
        self._latest: dict[str, zenoh.Subscriber] = {}
        self._token: zenoh.LivelinessToken | None = None  # this client's, at the lab selected
        self._last: dict[str, dict | None] = {}
        self._callbacks: list[tuple[str, Callable[[dict], None], zenoh.Subscriber]] = []
        self._alive = self._session.liveliness().declare_subscriber(
            ALL_LABS_ALIVE, self._on_alive, history=True
        )
        try:
            if lab_id is None:
                found = find_labs(self._session, connect_timeout)
                lab_id = found[0] if first and found else only_lab(found, endpoint)
            self.select(lab_id)
        except BaseException:
            self.close()
            raise

    @property
    def lab_id(self) -> str:
        """The lab this client talks to."""
        assert self._keys is not None
        return self._keys.lab_id

    def labs(self) -> dict[str, bool]:
        """Every lab seen since the client started, sorted by id: whether it is online now."""
        return self._directory.labs()

    def select(self, lab_id: str) -> None:
        """Talk to lab `lab_id` from now on: commands, telemetry, state, events, `connected`
        (callbacks given to `subscribe_*` follow). Raises LabIdError for an id that cannot be
        one."""
        keys = LabKeys(lab_id)
        with self._lock:
            old = [*self._latest.values(), *(sub for _, _, sub in self._callbacks)]
            callbacks = [(kind, callback) for kind, callback, _ in self._callbacks]
            self._keys = keys
            if self._directory.is_online(lab_id):
                self._connected.set()
            else:
                self._connected.clear()
        for subscriber in old:
            subscriber.undeclare()
        if self._token is not None:
            self._token.undeclare()
        # Held while this client's link to the lab is up: a control lock it holds is released
        # when it vanishes (docs/protocol.md, "The control lock").
        self._token = self._session.liveliness().declare_token(
            keys.client(client_id(self._session))
        )
        latest = {
            kind: self._session.declare_subscriber(
                getattr(keys, kind), zenoh.handlers.RingChannel(capacity)
            )
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

    def _on_alive(self, sample: zenoh.Sample) -> None:
        alive = sample.kind == zenoh.SampleKind.PUT
        self._directory.seen(str(sample.key_expr), alive)
        with self._lock:
            if self._keys is None or lab_id_of(str(sample.key_expr)) != self._keys.lab_id:
                return
            if alive:
                self._connected.set()
            else:
                self._connected.clear()

    def command(self, verb: str, timeout: float | None = None, **fields: object) -> dict:
        """Send `verb` with `fields` as its JSON payload; return the server's reply."""
        return self.request(verb, json.dumps(fields), timeout)

    def request(self, verb: str, payload: str | bytes, timeout: float | None = None) -> dict:
        """Send a raw payload to `lab/<id>/cmd/<verb>`; see `query`."""
        assert self._keys is not None
        return query(self._session, self._keys, verb, payload, timeout)

    def latest_telemetry(self) -> dict | None:
        """The newest telemetry message received so far (None before the first)."""
        return self._newest("telemetry")

    def latest_state(self) -> dict | None:
        """The newest `lab/<id>/state` message received so far (None before the first)."""
        return self._newest("state")

    def wait_telemetry(
        self,
        predicate: Callable[[dict], bool] = lambda _: True,
        timeout: float = 5.0,
        since_last_read: bool = False,
    ) -> dict:
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

    def subscribe_telemetry(self, callback: Callable[[dict], None]) -> None:
        """Call `callback(message)` for every telemetry message (on a Zenoh thread)."""
        self._subscribe("telemetry", callback)

    def subscribe_state(self, callback: Callable[[dict], None]) -> None:
        """Call `callback(message)` for every `lab/<id>/state` message (on a Zenoh thread)."""
        self._subscribe("state", callback)

    def subscribe_events(self, callback: Callable[[dict], None]) -> None:
        """Call `callback(event)` for every `lab/<id>/events` message (on a Zenoh thread)."""
        self._subscribe("events", callback)

    def close(self) -> None:
        subscribers = [*self._callbacks, *self._latest.items()]
        tokens = [self._token] if self._token is not None else []
        self._token = None
        for subscriber in [*tokens, self._alive, *(entry[-1] for entry in subscribers)]:
            subscriber.undeclare()
        self._callbacks.clear()
        self._latest.clear()
        self._session.close()

    def __enter__(self) -> "LabClient":
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def _declare_callback(self, kind: str, callback: Callable[[dict], None]) -> zenoh.Subscriber:
        def on_sample(sample: zenoh.Sample) -> None:
            callback(json.loads(sample.payload.to_bytes()))

        assert self._keys is not None
        return self._session.declare_subscriber(getattr(self._keys, kind), on_sample)

    def _subscribe(self, kind: str, callback: Callable[[dict], None]) -> None:
        subscriber = self._declare_callback(kind, callback)
        with self._lock:
            self._callbacks.append((kind, callback, subscriber))

    def _fresh(self, kind: str, newest_only: bool = False) -> list[dict]:
        """The messages received since the last read (at most BACKLOG[kind]), oldest first;
        with `newest_only`, the newest alone (the others are dropped unparsed)."""
        with self._lock:
            subscriber = self._latest[kind]
        samples = []
        while (sample := subscriber.try_recv()) is not None:
            samples.append(sample)
        if newest_only:
            samples = samples[-1:]
        messages = [json.loads(sample.payload.to_bytes()) for sample in samples]
        if messages:
            with self._lock:
                if self._latest.get(kind) is subscriber:  # not from a lab switched away from
                    self._last[kind] = messages[-1]
        return messages

    def _newest(self, kind: str) -> dict | None:
        self._fresh(kind, newest_only=True)
        with self._lock:
            return self._last[kind]


def query(
    session: zenoh.Session,
    keys: LabKeys,
    verb: str,
    payload: str | bytes,
    timeout: float | None = None,
) -> dict:
    """Send a raw payload to the lab's `lab/<id>/cmd/<verb>` and return its reply. The query's
    attachment is the client's id, its Zenoh session's id (`client_id`): the server's rate
    limit and control lock go by it. A missing reply becomes {"ok": false, "error": "<verb>:
    ..."} so callers handle one shape: "no reply within T s" when the timeout ran out, "closed
    unanswered after t s" when the query ended sooner with no reply (no lab behind the key, or
    one that dropped it: a full command queue)."""
    if timeout is None:
        timeout = SLOW_COMMAND_TIMEOUT_S if verb in SLOW_VERBS else COMMAND_TIMEOUT_S
    no_reply = {"ok": False, "error": f"{verb}: no reply within {timeout:g} s"}
    start = time.monotonic()
    replies = session.get(
        keys.cmd(verb), payload=payload, timeout=timeout, attachment=client_id(session)
    )
    for reply in replies:
        if reply.ok is None:  # Zenoh's own error, e.g. "Timeout" from an unanswered query
            error = reply.err.payload.to_string()
            return no_reply if error == "Timeout" else {"ok": False, "error": f"{verb}: {error}"}
        try:
            return json.loads(reply.ok.payload.to_bytes())
        except ValueError:
            return {"ok": False, "error": f"{verb}: the reply is not JSON"}
    waited = time.monotonic() - start
    if waited < timeout * TIMED_OUT_FRACTION:
        error = (
            f"{verb}: the query was closed unanswered after {waited:.2g} s (no lab answers "
            f"{keys.cmd(verb)}, or it dropped the query: its queue of waiting commands was full)"
        )
        return {"ok": False, "error": error}
    return no_reply


def client_id(session: zenoh.Session) -> str:
    """The id a client sends with each command: its Zenoh session's id (32 hex digits)."""
    return str(session.zid())


def find_labs(session: zenoh.Session, timeout: float) -> list[str]:
    """The ids of the labs reachable through `session` now (their liveliness tokens), sorted;
    waits up to `timeout` s for at least one (a sim process may still be starting)."""
    end = time.monotonic() + timeout
    while True:
        found = set()
        for reply in session.liveliness().get(ALL_LABS_ALIVE, timeout=1.0):
            if reply.ok is not None and (lab_id := lab_id_of(str(reply.ok.key_expr))):
                found.add(lab_id)
        if found or time.monotonic() > end:
            return sorted(found)
        time.sleep(0.05)


def only_lab(labs: list[str], endpoint: str) -> str:
    """The one lab of `labs`; LabNotFound when there is none or more than one."""
    if len(labs) == 1:
        return labs[0]
    if not labs:
        raise LabNotFound(f"no lab (sim process) seen at {endpoint}")
    raise LabNotFound(f"{len(labs)} labs at {endpoint}: {', '.join(labs)}; name one (lab_id)")


class LabUnreachable(zenoh.ZError):
    """No Zenoh session to an endpoint; the message says why, as far as it can be told."""


def open_session(
    endpoint: str, timeout: float, cancelled: Callable[[], bool] = lambda: False
) -> zenoh.Session:
    """Open a client session to `endpoint`, retrying for `timeout` s (or until `cancelled()`)
    while the server is still starting (a Zenoh client cannot open a session with nothing to
    connect to). Raises LabUnreachable saying whether anything listens there."""
    end = time.monotonic() + timeout
    config = client_config(endpoint)  # a LAB_ZENOH_CONFIG Zenoh cannot read raises ZError here
    while True:
        try:
            return zenoh.open(config)
        except zenoh.ZError as error:
            if time.monotonic() > end or cancelled():
                raise LabUnreachable(why_unreachable(endpoint)) from error
            time.sleep(0.05)


def why_unreachable(endpoint: str) -> str:
    """Why a Zenoh session to `endpoint` did not open. Zenoh says the same ("Unable to connect")
    for a server that is down and for one that refused the credentials; a plain TCP connection
    tells the two apart for tcp/ and tls/ endpoints: something that accepts it, then refuses the
    session, wants other credentials (or TLS)."""
    protocol, _, address = endpoint.partition("/")
    host, _, port = address.split("#", 1)[0].rpartition(":")
    credentials = credentials_from_env()
    if protocol in ("tcp", "tls") and port.isdigit():
        try:
            socket.create_connection((host.strip("[]"), int(port)), PROBE_TIMEOUT_S).close()
        except OSError as error:
            return f"nothing answers at {endpoint} ({error.strerror or error}): is the lab running?"
        if credentials is not None:
            return (
                f"{endpoint} refused the session: wrong user or password? ({ENV_USER}="
                f"{credentials.user!r} and {ENV_PASSWORD}; or it expects TLS: {ENV_CONFIG})"
            )
        return (
            f"{endpoint} refused the session: it may ask for a user and password "
            f"({ENV_USER}, {ENV_PASSWORD}) or TLS ({ENV_CONFIG})"
        )
    may = " (or the user or password are wrong)" if credentials is not None else ""
    return f"no Zenoh session to {endpoint}: is the lab running{may}?"
