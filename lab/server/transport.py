"""The Zenoh side of the sim process: configuration, the command queryable and the publishers.

No Python runs on Zenoh's threads in the sim process: commands land in a Zenoh ring channel and
the loop thread takes them out between ticks (`receive`), applies them and replies (`reply`).
What the loop publishes it encodes itself; a thread of ours (`PutThread`) puts the bytes.
See docs/protocol.md.
"""

import json
import os
import queue
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np
import zenoh

from lab.protocol import DEFAULT_ENDPOINT, DEFAULT_PORT, MAX_PAYLOAD_BYTES, LabKeys
from lab.server.access import (
    ENV_CONFIG,
    Credentials,
    ListenAccess,
    credentials_from_env,
    listen_access,
    read_users,
    remote_listen_refusal,
    usrpwd_settings,
)

COMMAND_QUEUE = 256  # queries waiting for the loop; beyond this the oldest get no reply
# Encoded messages waiting for the publisher thread; beyond this the caller puts them itself.
PUBLISH_BACKLOG = 64

_NO_SCOUTING = {"scouting/multicast/enabled": False, "scouting/gossip/enabled": False}


def _plain(value: object) -> object:
    """What msgspec cannot encode itself: numpy scalars and arrays as Python numbers and lists."""
    if isinstance(value, np.generic | np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot encode {type(value).__name__} as JSON")


# msgspec encodes a telemetry message in ~6 µs where json.dumps takes ~75 µs, inside the 1 ms tick
# that publishes it. Non-finite floats become null (json.dumps would write NaN, which is not JSON).
encode = msgspec.json.Encoder(enc_hook=_plain).encode


def server_config(
    port: int = DEFAULT_PORT,
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
    users_file: str | Path | None = None,
    credentials: Credentials | None = None,
    base_file: str | Path | None = None,
    mode: str = "peer",
) -> zenoh.Config:
    """Peer listening on 127.0.0.1:`port` only, no scouting; `listen`/`connect` are opt-ins
    (a non-empty `listen` replaces the loopback endpoint). `users_file` admits only the users in
    it, `credentials` are presented to whom it connects to (access.py); `base_file` is a Zenoh
    configuration (TLS, access control) these settings are written over. `mode="router"`: the
    same for `lab router`."""
    settings: dict[str, object] = {
        "mode": mode,
        "listen/endpoints": list(listen) or [f"tcp/127.0.0.1:{port}"],
        "connect/endpoints": list(connect),
    }
    if users_file is not None or credentials is not None:
        settings["transport/auth/usrpwd"] = usrpwd_settings(users_file, credentials)
    return _config(settings, base_file)


class AccessError(ValueError):
    """A listening set-up `lab serve` or `lab router` refuses; the message is the line to print."""


def checked_server_config(
    program: str,
    port: int,
    listen: Sequence[str],
    connect: Sequence[str] = (),
    users_file: str | None = None,
    base_file: str | None = None,
    opened: bool = False,
    mode: str = "peer",
) -> tuple[zenoh.Config, ListenAccess, Credentials | None]:
    """`server_config` for `program` (`lab serve`, `lab router`) with its checks: the users file
    read (its first user is presented on `connect` links, and the local UI logs in as it), then
    the configuration read back (`listen_access`) and refused if it listens beyond loopback
    unguarded without `opened`. Raises AccessError with the line to print."""
    credentials = None
    if users_file:
        try:
            credentials = read_users(users_file)[0]
        except (OSError, ValueError) as error:
            raise AccessError(f"{program}: --users: {error}") from None
    try:
        config = server_config(port, listen, connect, users_file, credentials, base_file, mode)
    except zenoh.ZError as error:  # a --zenoh-config it cannot read
        raise AccessError(f"{program}: --zenoh-config: {error}") from None
    access = listen_access(config)  # what the session will listen on and check, read back
    if refusal := remote_listen_refusal(program, access, opened):
        raise AccessError(refusal)
    return config, access, credentials


def client_config(
    endpoint: str = DEFAULT_ENDPOINT, credentials: Credentials | None = None
) -> zenoh.Config:
    """Client connecting to exactly `endpoint`, no scouting; presenting `credentials`, by
    default those of LAB_ZENOH_USER / LAB_ZENOH_PASSWORD if set, over the Zenoh configuration
    file LAB_ZENOH_CONFIG names if set (TLS: the CA to trust; access.py)."""
    settings: dict[str, object] = {"mode": "client", "connect/endpoints": [endpoint]}
    credentials = credentials or credentials_from_env()
    if credentials is not None:
        settings["transport/auth/usrpwd"] = usrpwd_settings(credentials=credentials)
    return _config(settings, os.environ.get(ENV_CONFIG) or None)


def _config(settings: dict[str, object], base_file: str | Path | None = None) -> zenoh.Config:
    """`settings` (keys are Zenoh configuration paths) over `base_file` or Zenoh's defaults,
    with scouting off."""
    config = zenoh.Config.from_file(str(base_file)) if base_file is not None else zenoh.Config()
    for key, value in (settings | _NO_SCOUTING).items():
        config.insert_json5(key, json.dumps(value))
    return config


@dataclass(frozen=True)
class Request:
    """One received command: the verb from the key, the decoded payload or why it is unreadable."""

    verb: str
    payload: object
    error: str | None
    query: zenoh.Query


def decode_query(query: zenoh.Query, keys: LabKeys) -> Request:
    """Verb from `lab/<id>/cmd/<verb>`; payload parsed as JSON (empty payload = {})."""
    verb = str(query.key_expr).removeprefix(keys.cmd_prefix)[:64]
    raw = query.payload.to_bytes() if query.payload is not None else b""
    if len(raw) > MAX_PAYLOAD_BYTES:
        return Request(verb, None, f"{verb}: payload larger than {MAX_PAYLOAD_BYTES} bytes", query)
    if not raw.strip():
        return Request(verb, {}, None, query)
    try:
        payload = json.loads(raw)
    except (ValueError, RecursionError) as exc:  # bad UTF-8 / JSON, or nesting too deep
        return Request(verb, None, f"{verb}: payload is not valid JSON ({exc})"[:300], query)
    if payload is None:
        return Request(verb, None, f"{verb}: payload must be a JSON object, got null", query)
    return Request(verb, payload, None, query)


class PutThread:
    """Zenoh `put`s on a thread of their own, in the order they were asked for.

    A put costs the caller 30 µs at the median and up to ~0.15 ms on a busy 2-core machine
    (it wakes Zenoh's sending thread), on the realtime loop's tick that publishes. zenoh-python's
    `put` releases the GIL, so on this thread it runs while the loop sleeps or on the other
    core; the loop only hands over the encoded bytes (docs/performance.md, round 10). A put that
    fails here is raised to the caller's next `put`. With PUBLISH_BACKLOG messages waiting (the
    thread starved for ~0.4 s at the loop's rates) the caller puts itself: nothing is dropped,
    nothing piles up, but that message may then arrive before older ones still waiting."""

    def __init__(self) -> None:
        self._queue: queue.SimpleQueue[tuple[zenoh.Publisher, bytes] | None] = queue.SimpleQueue()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="zenoh-put", daemon=True)
        self._thread.start()

    def put(self, publisher: zenoh.Publisher, payload: bytes) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error
        if self._queue.qsize() >= PUBLISH_BACKLOG:
            publisher.put(payload)
        else:
            self._queue.put((publisher, payload))

    def close(self) -> None:
        """Put what is waiting, then stop the thread."""
        self._queue.put(None)
        self._thread.join()

    def _run(self) -> None:
        while (item := self._queue.get()) is not None:
            publisher, payload = item
            try:
                publisher.put(payload)
            except Exception as error:  # handed to the caller's next put
                self._error = error


class ServerTransport:
    """The sim process's Zenoh session: one command queryable, three publishers and the
    liveliness token, all under the lab's keys (`lab/<lab_id>/...`). Messages are encoded by
    the caller and put by a `PutThread`."""

    def __init__(self, config: zenoh.Config, lab_id: str) -> None:
        self.keys = LabKeys(lab_id)
        self._session = zenoh.open(config)
        self._queryable = self._session.declare_queryable(
            self.keys.cmd("**"), zenoh.handlers.RingChannel(COMMAND_QUEUE)
        )
        self._telemetry = self._session.declare_publisher(self.keys.telemetry)
        self._state = self._session.declare_publisher(self.keys.state)
        self._events = self._session.declare_publisher(self.keys.events)
        self._alive = self._session.liveliness().declare_token(self.keys.alive)
        self._puts = PutThread()

    def receive(self) -> Request | None:
        """The oldest waiting command, without blocking."""
        query = self._queryable.try_recv()
        return None if query is None else decode_query(query, self.keys)

    def reply(self, request: Request, body: dict[str, object]) -> None:
        try:
            request.query.reply(request.query.key_expr, encode(body), express=True)
        except zenoh.ZError:
            pass  # the querier asked on a key we may not answer (wildcards) or has gone
        finally:
            request.query.drop()

    def publish_telemetry(self, message: dict[str, object]) -> None:
        self._puts.put(self._telemetry, encode(message))

    def publish_state(self, message: dict[str, object]) -> None:
        self._puts.put(self._state, encode(message))

    def publish_event(self, message: dict[str, object]) -> None:
        self._puts.put(self._events, encode(message))

    def close(self) -> None:
        self._puts.close()
        for entity in (self._alive, self._queryable, self._telemetry, self._state, self._events):
            entity.undeclare()
        self._session.close()
