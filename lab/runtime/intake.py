"""Commands taken in off the loop: who sent them, how often, how big, decoded and validated.

A thread of ours (`CommandIntake`) blocks on the command queryable's channel and does for each
query everything that does not need the session: it reads the client's id (the query's
attachment, docs/protocol.md "Clients"), refuses a client over its rate (`RATE_HZ`, `BURST`) or
with `CLIENT_QUEUE` commands already waiting, refuses a payload over `MAX_PAYLOAD_BYTES` before
reading it and one nested deeper than `MAX_PAYLOAD_DEPTH` before decoding it, decodes the JSON
and validates it into the verb's typed command (`parse_command`).
A refusal is answered from this thread at once and counted (`rejections`); only valid commands
wait, in one bounded queue per client, for the loop, which takes them round-robin between
clients (`take`) and does nothing with a command but apply it and reply.

Measured reason (issue 25): parsing on the loop's side let five clients sending 64 KB arrays cut
the loop's on-time fraction from 0.72 to 0.14-0.23. What this thread holds is bounded: at most
`CLIENT_QUEUE` commands for each of at most `MAX_CLIENTS` clients. With the loop's next
deadline given (`stand_aside_for`), no query is begun just before it (STAND_ASIDE_S).
"""

import re
import threading
import time
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass

import msgspec
import numpy as np
import zenoh

from lab.protocol import (
    CLIENT_ID_PATTERN,
    MAX_PAYLOAD_BYTES,
    MAX_PAYLOAD_DEPTH,
    LabKeys,
    ReleaseCommand,
    TakeCommand,
)
from lab.runtime.control_lock import ControlLock
from lab.runtime.scheduling import name_os_thread

RATE_HZ = 100.0  # commands a client may send per second, on average...
BURST = 50  # ...and at once (a token bucket of this size, refilled at RATE_HZ)
CLIENT_QUEUE = 16  # a client's valid commands waiting for the loop; beyond, "busy" replies
MAX_CLIENTS = 64  # clients remembered (their buckets and queues); the idle oldest are forgotten
# Queries this thread reads per second at most, over all clients (bursts of INTAKE_BURST): it
# shares the GIL with the loop, and five flooding clients sent it 7,700 queries/s, each read,
# refused and answered in Python (the loop lost 29 points of on-time). Beyond this it sleeps and
# Zenoh's channel (COMMAND_QUEUE, transport.py) drops the oldest queries unanswered.
INTAKE_RATE_HZ = 1000.0
INTAKE_BURST = 100
# A refused query takes this many of those: a flood (clients over their rate or the payload cap)
# is answered at INTAKE_RATE_HZ / REFUSAL_COST queries/s, Zenoh's channel dropping the rest
# unanswered as before, while valid commands still pass at INTAKE_RATE_HZ. The loop's cost of a
# flood is this thread's GIL time, ~80 µs of CPU per refusal answered (docs/reliability.md,
# "Where the flood's cost is"); an over-eager client still gets replies naming its rate or cap.
REFUSAL_COST = 4
ANONYMOUS = "anonymous"  # the client id of a query without an attachment
# The loop's next tick needs the GIL from its wake-up (a spin margin before its deadline) until
# the tick ends. Under a flood this thread spends ~80 µs of CPU per query, holding the GIL ~8 %
# of the time, and a loop wake-up inside that waited for it (the flood cost 7.7 points of
# on-time on a quiet machine while a loop beside it in another process lost none). So a query is
# not begun within STAND_ASIDE_S before the loop's deadline: this thread sleeps until
# TICK_ALLOWANCE_S after it (the flooded loop's gap to that loop beside it: 8-13 points without,
# 2.5-11 with, four A/B pairs; docs/reliability.md, "Where the flood's cost is").
STAND_ASIDE_S = 3e-4
TICK_ALLOWANCE_S = 2e-4

_decode = msgspec.json.Decoder().decode
# A JSON string, its escapes included (an unterminated one runs to the end): what is inside does
# not nest. Possessive: no backtracking, one pass over the payload.
_JSON_STRING = re.compile(rb'"(?:[^"\\]++|\\.)*+"?', re.S)
# A byte's step in nesting: +1 opens a list or an object, -1 (as int8) closes one, 0 otherwise.
_NESTING_STEPS = bytes(1 if b in b"[{" else 255 if b in b"]}" else 0 for b in range(256))


@dataclass(frozen=True)
class Request:
    """One command as the loop receives it: verb, the decoded payload, its typed command
    (None when `error` says why it is refused), the client's id and the query to answer."""

    verb: str
    payload: object
    error: str | None
    query: zenoh.Query | None
    command: object = None
    client: str = ANONYMOUS


class TokenBucket:
    """`burst` tokens, refilled at `rate` per second; a command takes one."""

    def __init__(self, rate: float, burst: float, now: float) -> None:
        self.rate, self.burst = rate, burst
        self.tokens, self.last = burst, now

    def take(self, now: float, cost: float = 1.0) -> bool:
        """Take `cost` tokens if there are as many (else none; a billionth of one short is
        rounding: after sleeping `wait_s(cost)` they are there)."""
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate)
        self.last = now
        if self.tokens < cost - 1e-9:
            return False
        self.tokens -= cost
        return True

    def wait_s(self, cost: float) -> float:
        """How long until `cost` tokens are there, as of the last `take`."""
        return max(0.0, (cost - self.tokens) / self.rate)


class _Client:
    def __init__(self, now: float) -> None:
        self.bucket = TokenBucket(RATE_HZ, BURST, now)
        self.queue: deque[Request] = deque()


def client_of(query: zenoh.Query) -> tuple[str, str | None]:
    """The client id a query carries in its attachment (ANONYMOUS without one), and an error
    if the attachment is not a valid id."""
    attachment = query.attachment
    if attachment is None:
        return ANONYMOUS, None
    raw = attachment.to_bytes()
    text = raw.decode("utf-8", "replace")
    if not CLIENT_ID_PATTERN.fullmatch(text):
        return ANONYMOUS, f"client id {text[:70]!r} in the attachment is not 1-64 of [A-Za-z0-9_.-]"
    return text, None


def nesting_depth(text: bytes) -> int:
    """How deep the lists and objects of JSON `text` nest (0 for a scalar), brackets inside
    strings left out; exact up to the first byte that is not JSON."""
    steps = _JSON_STRING.sub(b"", text).translate(_NESTING_STEPS)
    return int(np.frombuffer(steps, np.int8).cumsum(dtype=np.int32).max(initial=0))


def decode_payload(verb: str, query: zenoh.Query) -> tuple[object, str | None]:
    """The query's payload decoded as JSON (an empty payload is {}), or why it cannot be: over
    MAX_PAYLOAD_BYTES (checked before the bytes are read), nested deeper than MAX_PAYLOAD_DEPTH
    (checked before they are decoded), not JSON, null.

    The depth is checked first because the decoder recurses into each nested list and object
    until Python's recursion limit stops it (about 1,000 levels; a 16 KiB payload opens up to
    16,384): a garbage collection that falls on its deepest levels runs the collector's callbacks
    (the loop's `GcPauses`) and finalizers with no stack left, and their RecursionError is raised
    where nothing catches it (the wire fuzz's CI failure, tests/runtime/test_fuzz_wire.py)."""
    payload = query.payload
    if payload is None:
        return {}, None
    size = len(payload)
    if size > MAX_PAYLOAD_BYTES:
        return None, f"{verb}: payload of {size} bytes is over the {MAX_PAYLOAD_BYTES}-byte cap"
    raw = payload.to_bytes()
    if not raw.strip():
        return {}, None
    # Fewer brackets than the cap cannot nest deeper (every valid command): no scan.
    brackets = raw.count(b"[") + raw.count(b"{")
    if brackets > MAX_PAYLOAD_DEPTH and (depth := nesting_depth(raw)) > MAX_PAYLOAD_DEPTH:
        return None, (
            f"{verb}: payload is nested deeper than {MAX_PAYLOAD_DEPTH} lists and objects "
            f"({depth} levels)"
        )
    try:
        value = _decode(raw)
    except msgspec.DecodeError as exc:  # bad UTF-8 or JSON
        return None, f"{verb}: payload is not valid JSON ({exc})"[:300]
    if value is None:
        return None, f"{verb}: payload must be a JSON object, got null"
    return value, None


class CommandIntake:
    """Receives the queries of `queryable` on a thread of its own, refuses and answers what is
    wrong, and keeps valid commands for the loop (`take`). `validate(verb, payload)` returns
    the typed command or raises ValueError naming what is wrong; `answer(query, body)` replies
    and drops a query. `presence` (a liveliness subscriber on `keys.clients`, if any) tells
    which clients' links are up, for the control lock (`take` and `release` are answered here:
    lab/runtime/control_lock.py)."""

    def __init__(
        self,
        queryable: zenoh.Queryable,
        keys: LabKeys,
        validate: Callable[[str, object], object],
        answer: Callable[[zenoh.Query, dict[str, object]], None],
        clock: Callable[[], float] = time.monotonic,
        presence: zenoh.Subscriber | None = None,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self._queryable = queryable
        self._presence = presence
        self.lock = ControlLock()
        self._keys = keys
        self._validate = validate
        self._answer = answer
        self._clock, self._sleep = clock, sleep
        self._clients: OrderedDict[str, _Client] = OrderedDict()  # least recently heard first
        self._turn: deque[str] = deque()  # clients with commands waiting, in turn
        self._lock = threading.Lock()
        self._rejected = 0
        self._last_rejection = ("", "")
        self.payload_bytes = 0  # read so far, refused or not (lab/runtime/heap_trim.py)
        self._next_tick: Callable[[], float] | None = None
        self._thread = threading.Thread(target=self._run, name="command-intake", daemon=True)
        self._thread.start()

    def stand_aside_for(self, next_tick: Callable[[], float]) -> None:
        """Begin no query within STAND_ASIDE_S before `next_tick()` (the loop's next deadline,
        on this intake's clock)."""
        self._next_tick = next_tick

    def take(self) -> Request | None:
        """The next valid command, one client after the other; None when none waits (told
        without the lock: the loop asks every tick, and a command appended meanwhile is taken
        next tick)."""
        if not self._turn:
            return None
        with self._lock:
            if not self._turn:
                return None
            name = self._turn.popleft()
            client = self._clients[name]
            request = client.queue.popleft()
            if client.queue:
                self._turn.append(name)
            return request

    def rejections(self) -> tuple[int, str, str]:
        """Commands refused here since the last call, and the verb and error of the last one."""
        with self._lock:
            count, self._rejected = self._rejected, 0
            return (count, *self._last_rejection)

    def join(self, timeout: float) -> None:
        """Wait for the thread to end (it does when the Zenoh session closes)."""
        self._thread.join(timeout)

    def _run(self) -> None:
        name_os_thread()
        budget = TokenBucket(INTAKE_RATE_HZ, INTAKE_BURST, self._clock())
        while True:
            try:
                query = self._queryable.recv()
            except zenoh.ZError:  # the channel closed with the session
                return
            self.stand_aside()
            cost = REFUSAL_COST if self.receive(query) else 1.0
            # One sleep for the tokens missing: each wake-up takes the GIL from the loop.
            while not budget.take(self._clock(), cost):
                self._sleep(budget.wait_s(cost))

    def stand_aside(self) -> None:
        """Sleep past the loop's next tick if it begins within STAND_ASIDE_S (or began less
        than TICK_ALLOWANCE_S ago); called before each query."""
        if self._next_tick is None:
            return
        gap = self._next_tick() - self._clock()
        if -TICK_ALLOWANCE_S < gap < STAND_ASIDE_S:
            self._sleep(gap + TICK_ALLOWANCE_S)

    def receive(self, query: zenoh.Query) -> bool:
        """Refuse and answer `query` (True), or keep it for the loop or answer it as a valid
        `take`/`release` (False)."""
        if (sent := query.payload) is not None:
            self.payload_bytes += len(sent)
        verb = str(query.key_expr).removeprefix(self._keys.cmd_prefix)[:64]
        client, error = client_of(query)
        if error is None:
            error = self._admit(client, verb)
        if error is None:
            error = self._locked_out(client, verb)
        if error is None:
            payload, error = decode_payload(verb, query)
        if error is None:
            try:
                command = self._validate(verb, payload)
            except ValueError as exc:
                error = str(exc)
        if error is None and isinstance(command, TakeCommand | ReleaseCommand):
            with self._lock:
                lock = self.lock
                error = lock.take(client) if verb == "take" else lock.release(client)
            if error is None:
                self._answer(query, {"ok": True, "control": {"holder": lock.holder}})
                return False
        if error is None:
            with self._lock:
                entry = self._clients[client]  # `_admit` keeps it: only this thread forgets
                if len(entry.queue) < CLIENT_QUEUE:
                    if not entry.queue:
                        self._turn.append(client)
                    entry.queue.append(Request(verb, payload, None, query, command, client))
                    return False
            error = f"{verb}: busy: {CLIENT_QUEUE} commands of client {client} wait already"
        with self._lock:
            self._rejected += 1
            self._last_rejection = (verb, error[:300])
        self._answer(query, {"ok": False, "error": error})
        return True

    def holder(self) -> str | None:
        """The control lock's holder now (None: free), after the liveliness changes seen
        since the last look: what telemetry and `info` report (lab/runtime/transport.py)."""
        with self._lock:
            self._follow_presence(self._clock())
            return self.lock.holder

    def _locked_out(self, client: str, verb: str) -> str | None:
        """Why the control lock refuses `verb` from `client` now, after the liveliness
        changes seen since the last query (a holder whose link dropped loses it)."""
        with self._lock:
            self._follow_presence(self._clock())
            return self.lock.refusal(client, verb)

    def _follow_presence(self, now: float) -> None:
        """Feed the clients' liveliness changes to the lock and let a gone holder's expire
        (with `_lock` held)."""
        while self._presence is not None and (sample := self._presence.try_recv()):
            key = str(sample.key_expr)
            alive = sample.kind == zenoh.SampleKind.PUT
            self.lock.seen(key.rsplit("/", 1)[-1], alive, now)
        self.lock.expire(now)

    def _admit(self, client: str, verb: str) -> str | None:
        """None if `client` may send one more command now, else why not (its rate)."""
        now = self._clock()
        with self._lock:
            entry = self._clients.get(client)
            if entry is None:
                if len(self._clients) >= MAX_CLIENTS and not self._forget_one():
                    return (
                        f"{verb}: the server is busy: {MAX_CLIENTS} clients have commands waiting"
                    )
                entry = self._clients[client] = _Client(now)
            self._clients.move_to_end(client)
            if not entry.bucket.take(now):
                return (
                    f"{verb}: rate limit: client {client} sent more than {RATE_HZ:g} commands/s "
                    f"(bursts of {BURST}); this one was not applied"
                )
        return None

    def _forget_one(self) -> bool:
        """Forget the least recently heard client with nothing waiting; False if all wait."""
        for name, entry in self._clients.items():
            if not entry.queue:
                del self._clients[name]
                return True
        return False
