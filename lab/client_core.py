"""The one client core of the lab (docs/protocol.md): a Zenoh client session to the labs behind
an endpoint, the labs it sees, the one it talks to, its client token there, commands as typed
structs or verb and fields, and the messages it reads. `lab.client.LabClient` (scripts, tests,
`lab teleop`) and the browser UI's `lab.ui.link.Link` are both built on `LabLink`; neither
imports anything of the server.
"""

from __future__ import annotations  # zenoh's generic types are not subscriptable at run time

import json
import socket
import time
from collections.abc import Callable, Mapping
from typing import Any, Literal

import msgspec
import zenoh

from lab.directory import LabDirectory
from lab.protocol import ALL_LABS_ALIVE, CommandStruct, LabKeys, lab_id_of
from lab.zenoh_config import ENV_CONFIG, ENV_PASSWORD, ENV_USER, client_config, credentials_from_env

COMMAND_TIMEOUT_S = 2.0
# robot / scene switches rebuild the session; `floor` replies after measuring (up to 10 s)
SLOW_COMMAND_TIMEOUT_S = 20.0
SLOW_VERBS = ("robot", "scene", "floor")
# A query that ends with no reply before this fraction of its timeout was closed, not timed out.
TIMED_OUT_FRACTION = 0.9
PROBE_TIMEOUT_S = 2.0  # a TCP connection that tells "nothing there" from "credentials refused"
ALIVE_QUEUE = 256  # liveliness changes a link without a callback keeps between two polls

Channel = Literal["telemetry", "state", "events"]
Reply = dict[str, Any]  # a reply as JSON (lab.protocol.messages.Reply types it)
_decode = msgspec.json.Decoder().decode


class LabNotFound(LookupError):
    """No lab, or several and none chosen, behind a client's endpoint."""


# zenoh's stubs mark ZError final; it is subclassed fine at run time, and callers catch ZError
class LabUnreachable(zenoh.ZError):  # type: ignore[misc]
    """No Zenoh session to an endpoint; the message says why, as far as it can be told."""


class LabLink:
    """A Zenoh client session to the labs behind `endpoint` (opened within `open_timeout` s or
    until `cancelled()`) and the labs it sees (`directory`, from their liveliness tokens). With
    `on_alive`, Zenoh's threads feed the directory and call `on_alive(about_selected, alive)`
    for each change; without, the owner drains the changes with `poll_alive` (the UI's render
    loop: no Python on Zenoh's threads). The lab talked to is the one `select`ed, where the
    link holds its client token (the control lock goes with it: docs/protocol.md). `role`
    ("ui", "teleop"; empty for a script) prefixes the client id, so that the lock's refusals
    say what kind of client holds it."""

    def __init__(
        self,
        endpoint: str,
        open_timeout: float,
        on_alive: Callable[[bool, bool], None] | None = None,
        cancelled: Callable[[], bool] = lambda: False,
        role: str = "",
    ) -> None:
        self.endpoint = endpoint
        self.role = role
        self.directory = LabDirectory()
        self.keys: LabKeys | None = None
        self._token: zenoh.LivelinessToken | None = None
        self._on_alive = on_alive
        self.session = open_session(endpoint, open_timeout, cancelled)
        handler: zenoh.handlers.FifoChannel[zenoh.Sample] | Callable[[zenoh.Sample], None] = (
            zenoh.handlers.FifoChannel(ALIVE_QUEUE) if on_alive is None else self._alive_sample
        )
        self.alive: zenoh.Subscriber[Any] = self.session.liveliness().declare_subscriber(
            ALL_LABS_ALIVE, handler, history=True
        )

    @property
    def lab_id(self) -> str | None:
        """The lab talked to (None before one is selected)."""
        return None if self.keys is None else self.keys.lab_id

    @property
    def client_id(self) -> str:
        """The id this link sends with each command (the query's attachment)."""
        return client_id(self.session, self.role)

    def poll_alive(self) -> bool:
        """Take the liveliness changes seen since the last call into `directory` (a link
        without `on_alive`); whether anything changed."""
        changed = False
        while (sample := self.alive.try_recv()) is not None:
            changed |= self.directory.seen(str(sample.key_expr), _is_put(sample))
        return changed

    def _alive_sample(self, sample: zenoh.Sample) -> None:
        self.directory.seen(str(sample.key_expr), _is_put(sample))
        keys = self.keys
        assert self._on_alive is not None
        self._on_alive(keys is not None and str(sample.key_expr) == keys.alive, _is_put(sample))

    def select(self, lab_id: str) -> LabKeys:
        """Talk to lab `lab_id` from now on: its keys, with this link's client token there.
        Raises LabIdError for an id that cannot be one, changing nothing."""
        keys = LabKeys(lab_id)
        if self._token is not None:
            undeclare(self._token)
        self._token = self.session.liveliness().declare_token(keys.client(self.client_id))
        self.keys = keys
        return keys

    def subscribe(
        self,
        channel: Channel,
        handler: Callable[[zenoh.Sample], None] | zenoh.handlers.RingChannel[zenoh.Sample],
    ) -> zenoh.Subscriber[Any]:
        """A subscriber to `channel` of the lab selected (the caller undeclares it)."""
        keys = self.keys
        assert keys is not None, "select a lab first"
        key = {"telemetry": keys.telemetry, "state": keys.state, "events": keys.events}[channel]
        return self.session.declare_subscriber(key, handler)

    def send(self, command: CommandStruct, timeout: float | None = None) -> Reply:
        """Send one typed command to the lab selected; its reply."""
        return self.request(command.VERB, msgspec.json.encode(command), timeout)

    def command(
        self, verb: str, fields: Mapping[str, object] | None = None, timeout: float | None = None
    ) -> Reply:
        """Send `verb` with `fields` as its JSON payload (unchecked here: the server names what
        is wrong); its reply."""
        return self.request(verb, json.dumps(dict(fields or {})), timeout)

    def request(self, verb: str, payload: str | bytes, timeout: float | None = None) -> Reply:
        """Send a raw payload to `lab/<id>/cmd/<verb>` of the lab selected; see `query`."""
        if self.keys is None:
            return {"ok": False, "error": f"{verb}: no lab seen yet"}
        return query(self.session, self.keys, verb, payload, timeout, self.client_id)

    def close(self) -> None:
        """Undeclare the client token and the liveliness subscriber, close the session."""
        undeclare(*([self._token] if self._token is not None else []), self.alive)
        self._token = None
        self.session.close()  # type: ignore[no-untyped-call]  # (zenoh's stubs)


def undeclare(*entities: zenoh.Subscriber[Any] | zenoh.LivelinessToken) -> None:
    """Undeclare subscribers and tokens (zenoh's stubs leave `undeclare` untyped)."""
    for entity in entities:
        entity.undeclare()  # type: ignore[no-untyped-call]


def _is_put(sample: zenoh.Sample) -> bool:
    return sample.kind == zenoh.SampleKind.PUT


def decode_message(sample: zenoh.Sample) -> dict[str, Any]:
    """A telemetry, state or event sample as JSON (lab.protocol.messages and .events type
    them: `decode`, `decode_event`)."""
    message: dict[str, Any] = _decode(sample.payload.to_bytes())
    return message


def query(
    session: zenoh.Session,
    keys: LabKeys,
    verb: str,
    payload: str | bytes,
    timeout: float | None = None,
    client: str | None = None,
) -> Reply:
    """Send a raw payload to the lab's `lab/<id>/cmd/<verb>` and return its reply. The query's
    attachment is the client's id, `client` or else its Zenoh session's id (`client_id`): the
    server's rate limit and control lock go by it. A missing reply becomes {"ok": false,
    "error": "<verb>: ..."} so callers handle one shape: "no reply within T s" when the timeout
    ran out, "closed unanswered after t s" when the query ended sooner with no reply (no lab
    behind the key, or one that dropped it: a full command queue)."""
    if timeout is None:
        timeout = SLOW_COMMAND_TIMEOUT_S if verb in SLOW_VERBS else COMMAND_TIMEOUT_S
    no_reply: Reply = {"ok": False, "error": f"{verb}: no reply within {timeout:g} s"}
    start = time.monotonic()
    replies = session.get(
        keys.cmd(verb),
        payload=payload,
        timeout=timeout,
        attachment=client_id(session) if client is None else client,
    )
    for reply in replies:
        if reply.ok is None:  # Zenoh's own error, e.g. "Timeout" from an unanswered query
            error = reply.err.payload.to_string() if reply.err is not None else "no reply"
            return no_reply if error == "Timeout" else {"ok": False, "error": f"{verb}: {error}"}
        try:
            answer: Reply = _decode(reply.ok.payload.to_bytes())
        except msgspec.DecodeError:
            return {"ok": False, "error": f"{verb}: the reply is not JSON"}
        return answer
    waited = time.monotonic() - start
    if waited < timeout * TIMED_OUT_FRACTION:
        error = (
            f"{verb}: the query was closed unanswered after {waited:.2g} s (no lab answers "
            f"{keys.cmd(verb)}, or it dropped the query: its queue of waiting commands was full)"
        )
        return {"ok": False, "error": error}
    return no_reply


def client_id(session: zenoh.Session, role: str = "") -> str:
    """The id a client sends with each command: its Zenoh session's id (32 hex digits),
    prefixed with its `role` and a dash when it has one ("ui-3f0c…")."""
    zid = str(session.zid())
    return f"{role}-{zid}" if role else zid


def find_labs(session: zenoh.Session, timeout: float) -> list[str]:
    """The ids of the labs reachable through `session` now (their liveliness tokens), sorted;
    waits up to `timeout` s for at least one (a sim process may still be starting).

    Each look waits for every lab's answer for the rest of `timeout` (at least 1 s): a get ends
    as soon as all have answered, and a lab whose answer is late on a busy machine must not be
    missed (a client would then take the one that answered as the only lab)."""
    end = time.monotonic() + timeout
    while True:
        found = set()
        wait_s = max(1.0, end - time.monotonic())
        for reply in session.liveliness().get(ALL_LABS_ALIVE, timeout=wait_s):
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
