"""The Zenoh side of the sim process: configuration, the command queryable and the publishers.

No Python runs on Zenoh's threads in the sim process: commands land in a Zenoh ring channel, a
thread of ours (`lab.runtime.intake.CommandIntake`) takes them out, refuses and answers what is
wrong (rate, size, JSON, validation) and keeps the valid ones, typed, for the loop thread, which
takes them between ticks (`receive`), applies them and replies (`reply`). What the loop
publishes it encodes itself; another thread of ours (`PutThread`) puts the bytes.
See docs/protocol.md.
"""

import queue
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

import msgspec
import numpy as np
import zenoh

from lab.protocol import DEFAULT_PORT, LabKeys, parse_command
from lab.runtime.access import ListenAccess, listen_access, read_users, remote_listen_refusal
from lab.runtime.heap_trim import HeapTrimmer
from lab.runtime.intake import CommandIntake, Request
from lab.runtime.scheduling import name_os_thread
from lab.zenoh_config import Credentials, usrpwd_settings, zenoh_config

# Queries Zenoh keeps for the intake thread; beyond this the oldest get no reply. The intake
# answers each at once, so this fills only while that thread is starved, as under a flood: then
# it holds this many queries (of up to MAX_MESSAGE_BYTES each): at 256 a flood of 64 KB commands
# kept 16 MB in it (7 % of the sim process; benchmarks/zenoh_flood_memory.py), at 128 8 MB. A
# client's burst of 100 still fits (its rate limit answers it, tests/client/test_client.py).
COMMAND_QUEUE = 128
# The largest message Zenoh takes in (its `transport/link/rx/max_message_size`, 1 GiB by
# default: one query could make the sim process allocate that much). A larger one is dropped by
# Zenoh unanswered (its sender's query times out); up to this size a payload over the protocol's
# MAX_PAYLOAD_BYTES (16 KiB) is refused with a reply naming the cap (lab/runtime/intake.py), the
# wire fuzz's largest commands included (tests/runtime/test_fuzz_wire.py: up to four fields of
# 1 MB each; at 1.5 MiB such a command went unanswered).
MAX_MESSAGE_BYTES = 8 * 1024 * 1024
INTAKE_STOP_S = 2.0  # how long `close` waits for the intake thread
MAX_CLIENT_CHANGES = 1024  # clients' liveliness changes kept between two commands (the oldest go)
# Encoded messages waiting for the publisher thread; beyond this the caller puts them itself.
PUBLISH_BACKLOG = 64


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
    same for `lab router`. Shared memory is off (see below)."""
    settings: dict[str, object] = {
        "mode": mode,
        "listen/endpoints": list(listen) or [f"tcp/127.0.0.1:{port}"],
        "connect/endpoints": list(connect),
        # No shared memory with local clients: under a flood of 64 KB queries the process
        # mapped their SHM pools (16 MB each) and kept ~100 MB; without it a bare queryable
        # took 11 MB (its 256-query channel), bounded (benchmarks/zenoh_flood_memory.py,
        # docs/reliability.md). Messages here are a few KB: loopback TCP carries them.
        "transport/shared_memory/enabled": False,
    }
    if mode == "peer":  # the sim process (a router forwards what its labs publish, any size)
        settings["transport/link/rx/max_message_size"] = MAX_MESSAGE_BYTES
    if users_file is not None or credentials is not None:
        settings["transport/auth/usrpwd"] = usrpwd_settings(users_file, credentials)
    return zenoh_config(settings, base_file)


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


class PutThread:
    """Zenoh `put`s on a thread of their own, in the order they were asked for.

    A put costs the caller 30 µs at the median and up to ~0.15 ms on a busy 2-core machine
    (it wakes Zenoh's sending thread), on the realtime loop's tick that publishes. zenoh-python's
    `put` releases the GIL, so on this thread it runs while the loop sleeps or on the other
    core; the loop only hands over the encoded bytes (docs/performance.md, "Why the loop is built
    this way"). A put that fails here is raised to the caller's next `put`. With PUBLISH_BACKLOG
    messages waiting (the thread starved for ~0.4 s at the loop's rates) the caller puts itself:
    nothing is dropped, nothing piles up, but that message may then arrive before older ones still
    waiting."""

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
        name_os_thread()
        while (item := self._queue.get()) is not None:
            publisher, payload = item
            try:
                publisher.put(payload)
            except Exception as error:  # handed to the caller's next put
                self._error = error


class ServerTransport:
    """The sim process's Zenoh session: one command queryable, three publishers and the
    liveliness token, all under the lab's keys (`lab/<lab_id>/...`). Commands are validated by
    `validate(verb, payload)` (the typed command, or a ValueError naming what is wrong) on the
    intake thread. Messages are encoded by the caller and put by a `PutThread`."""

    def __init__(
        self,
        config: zenoh.Config,
        lab_id: str,
        validate: Callable[[str, object], object] = parse_command,
    ) -> None:
        self.keys = LabKeys(lab_id)
        self._session = zenoh.open(config)
        self._queryable = self._session.declare_queryable(
            self.keys.cmd("**"), zenoh.handlers.RingChannel(COMMAND_QUEUE)
        )
        # Clients' liveliness tokens: the control lock is released when its holder's vanishes.
        self._clients = self._session.liveliness().declare_subscriber(
            self.keys.clients, zenoh.handlers.RingChannel(MAX_CLIENT_CHANGES), history=True
        )
        self._intake = CommandIntake(
            self._queryable, self.keys, validate, answer, presence=self._clients
        )
        self._telemetry = self._session.declare_publisher(self.keys.telemetry)
        self._state = self._session.declare_publisher(self.keys.state)
        self._events = self._session.declare_publisher(self.keys.events)
        self._alive = self._session.liveliness().declare_token(self.keys.alive)
        self._puts = PutThread()
        self._trimmer = HeapTrimmer(lambda: self._intake.payload_bytes)

    def receive(self) -> Request | None:
        """The next valid command (one client after another), without blocking."""
        return self._intake.take()

    def stand_aside_for(self, next_tick: Callable[[], float]) -> None:
        """Let the command intake begin no query just before the loop's next tick
        (`next_tick()`: its deadline, time.monotonic; lab/runtime/intake.py)."""
        self._intake.stand_aside_for(next_tick)

    def rejections(self) -> tuple[int, str, str]:
        """Commands the intake refused since the last call; the verb and error of the last."""
        return self._intake.rejections()

    def reply(self, request: Request, body: dict[str, object]) -> None:
        if request.verb == "info" and body.get("ok"):
            body = {**body, "control": self._control()}
        answer(request.query, body)

    def publish_telemetry(self, message: dict[str, object]) -> None:
        message["control"] = self._control()
        self._puts.put(self._telemetry, encode(message))

    def _control(self) -> dict[str, object]:
        """Who holds the control lock, as telemetry and `info` carry it (the page greys its
        controls while another client holds it: docs/ui.md)."""
        return {"holder": self._intake.holder()}

    def publish_state(self, message: dict[str, object]) -> None:
        self._puts.put(self._state, encode(message))

    def publish_event(self, message: dict[str, object]) -> None:
        self._puts.put(self._events, encode(message))

    def close(self) -> None:
        self._puts.close()
        self._trimmer.close()
        for entity in (self._alive, self._clients, self._telemetry, self._state, self._events):
            entity.undeclare()
        # The queryable is the intake thread's while it waits in `recv` (undeclaring it then
        # fails): closing the session closes its channel, which ends the wait.
        self._session.close()
        self._intake.join(INTAKE_STOP_S)


def answer(query: zenoh.Query, body: dict[str, object]) -> None:
    """Reply `body` (JSON) to `query` on its key and drop it."""
    try:
        query.reply(query.key_expr, encode(body), express=True)
    except zenoh.ZError:
        pass  # the querier asked on a key we may not answer (wildcards) or has gone
    finally:
        query.drop()
