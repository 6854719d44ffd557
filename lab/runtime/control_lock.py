"""The control lock: which client may change the world (docs/protocol.md, "The control lock").

Pure bookkeeping, fed by the command intake (lab/runtime/intake.py) with the client ids of
commands and the liveliness of clients (`lab/<id>/clients/<client id>`). With no holder every
client may send every command, as before the lock existed. A client `take`s it when it is free
(or holds it already) and `release`s it; while it is held, commands that change the world from
any other client are refused with an error naming the holder; `READ_ONLY_VERBS` are always
allowed. The holder's link dropping (its liveliness token gone) releases the lock after
`GRACE_S`, the velocity deadman's timeout and ramp (lab/runtime/deadman.py): by then the robot has
stopped.
"""

from lab.protocol import READ_ONLY_VERBS

GRACE_S = 1.0  # = DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S


class ControlLock:
    """Holder of the lock (a client id or None) and the clients whose link is up."""

    def __init__(self) -> None:
        self.holder: str | None = None
        self._present: set[str] = set()
        self._gone_since: dict[str, float] = {}

    def seen(self, client: str, alive: bool, now: float) -> None:
        """`client`'s liveliness token appeared (`alive`) or vanished at `now` (s)."""
        if alive:
            self._present.add(client)
            self._gone_since.pop(client, None)
        else:
            self._present.discard(client)
            self._gone_since[client] = now

    def expire(self, now: float) -> str | None:
        """Release the lock if its holder's link has been down GRACE_S; the holder released."""
        holder = self.holder
        gone = self._gone_since.get(holder) if holder is not None else None
        if gone is None or now - gone < GRACE_S:
            return None
        self.holder = None
        return holder

    def take(self, client: str) -> str | None:
        """Give the lock to `client`; None if it did, else why not (naming the holder)."""
        if self.holder not in (None, client):
            return f"take: client {self.holder} holds the control lock"
        if client not in self._present:
            return (
                f"take: client {client} has no liveliness token lab/<id>/clients/{client}: the "
                "lock is released when its holder's link drops, which the server must see"
            )
        self.holder = client
        return None

    def release(self, client: str) -> str | None:
        """Free the lock held by `client`; None if it did, else why not."""
        if self.holder != client:
            held = "nobody" if self.holder is None else f"client {self.holder}"
            return f"release: client {client} does not hold the control lock ({held} does)"
        self.holder = None
        return None

    def refusal(self, client: str, verb: str) -> str | None:
        """Why `client` may not send `verb` now (naming the holder), or None if it may."""
        if self.holder is None or self.holder == client or verb in READ_ONLY_VERBS:
            return None
        return (
            f"{verb}: client {self.holder} holds the control lock; this client ({client}) may "
            "only read until it is released"
        )
