"""The labs a client sees on its Zenoh network, from their liveliness tokens (`lab/<id>/alive`).

A lab whose token appears is online; one whose token vanishes (its sim process died, or the link
to it or the router between broke) stays listed as offline until it comes back. `LabClient`,
`lab teleop` and the browser UI keep one each; Zenoh's threads may feed it while another thread
reads it, hence the lock.
"""

import threading

from lab.protocol import lab_id_of


class LabDirectory:
    """Lab id -> online, for every lab seen since the client started."""

    def __init__(self) -> None:
        self._online: dict[str, bool] = {}
        self._lock = threading.Lock()

    def seen(self, key: str, alive: bool) -> bool:
        """A liveliness sample on `key` (a PUT is `alive`); whether it changed the directory.
        Keys that name no lab are ignored."""
        lab_id = lab_id_of(key)
        if lab_id is None:
            return False
        with self._lock:
            changed = self._online.get(lab_id) != alive
            self._online[lab_id] = alive
        return changed

    def labs(self) -> dict[str, bool]:
        """Every lab seen, sorted by id: whether it is online now."""
        with self._lock:
            return dict(sorted(self._online.items()))

    def is_online(self, lab_id: str) -> bool:
        with self._lock:
            return self._online.get(lab_id, False)

    def online(self) -> list[str]:
        """The ids of the labs online now, sorted."""
        return [lab_id for lab_id, alive in self.labs().items() if alive]

    def next_online(self, lab_id: str | None) -> str | None:
        """The online lab after `lab_id` (see `next_online`)."""
        return next_online(self.labs(), lab_id)


def next_online(labs: dict[str, bool], lab_id: str | None) -> str | None:
    """The online lab of `labs` (id -> online) after `lab_id` in id order, wrapping round; None
    when none is online. What a "next lab" key steps to."""
    online = sorted(other for other, alive in labs.items() if alive)
    later = [other for other in online if lab_id is None or other > lab_id]
    return next(iter(later or online), None)
