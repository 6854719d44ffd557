"""Which browser holds control; the others watch read-only.

The browsers of one UI share its Zenoh link, one client of the lab, so the lab's control lock
(docs/protocol.md, "The control lock") is the UI's while any of its browsers holds control:
the first browser to take control `take`s it, the last to let go `release`s it (`server_lock`
sends the verb). A lock another client holds is that client's: the UI's commands are then
refused with an error naming it, which the browser shows."""

import threading
from collections.abc import Callable


class ControlOwnership:
    """One controlling client id (or none). The first client to connect takes control when free."""

    def __init__(self, server_lock: Callable[[str], None] = lambda verb: None) -> None:
        self._owner: int | None = None
        self._lock = threading.Lock()
        self._server_lock = server_lock

    @property
    def owner(self) -> int | None:
        return self._owner

    def is_owner(self, client_id: int) -> bool:
        return self._owner == client_id

    def take(self, client_id: int) -> int | None:
        """Give control to `client_id`; returns the previous owner."""
        with self._lock:
            previous, self._owner = self._owner, client_id
        if previous is None:
            self._server_lock("take")
        return previous

    def claim_if_free(self, client_id: int) -> bool:
        with self._lock:
            claimed = self._owner is None
            if claimed:
                self._owner = client_id
            owner = self._owner == client_id
        if claimed:
            self._server_lock("take")
        return owner

    def release(self, client_id: int) -> bool:
        """Drop control if `client_id` holds it; returns whether it did."""
        with self._lock:
            if self._owner != client_id:
                return False
            self._owner = None
        self._server_lock("release")
        return True
