"""Which browser holds control; the others watch read-only."""

import threading


class ControlOwnership:
    """One controlling client id (or none). The first client to connect takes control when free."""

    def __init__(self) -> None:
        self._owner: int | None = None
        self._lock = threading.Lock()

    @property
    def owner(self) -> int | None:
        return self._owner

    def is_owner(self, client_id: int) -> bool:
        return self._owner == client_id

    def take(self, client_id: int) -> int | None:
        """Give control to `client_id`; returns the previous owner."""
        with self._lock:
            previous, self._owner = self._owner, client_id
            return previous

    def claim_if_free(self, client_id: int) -> bool:
        with self._lock:
            if self._owner is None:
                self._owner = client_id
            return self._owner == client_id

    def release(self, client_id: int) -> bool:
        """Drop control if `client_id` holds it; returns whether it did."""
        with self._lock:
            if self._owner != client_id:
                return False
            self._owner = None
            return True
