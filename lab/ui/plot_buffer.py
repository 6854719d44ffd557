"""Rolling time-series buffers for the live plots."""

import numpy as np

# s: a sample this much older than the newest is a rewound clock (Reset, a scene switch); a
# sample less old arrived out of order (a telemetry message that the sim process's put thread
# let a newer one overtake) and is dropped. Clearing on it emptied every chart now and then,
# leaving a slice of a second drawn, or none.
REWIND_S = 0.5


class RollingBuffer:
    """The last `window` seconds of `n` channels sampled at irregular times.

    Appending a time more than REWIND_S before the newest sample (a reset rewound the clock)
    clears the buffer; a time before the newest by less is out of order and dropped, so the
    times stay sorted. Storage is a fixed ring of `capacity` samples, so memory does not grow.
    """

    def __init__(self, n: int, window: float = 10.0, capacity: int = 2048) -> None:
        self.n = n
        self.window = window
        self._t = np.zeros(capacity)
        self._y = np.zeros((capacity, n))
        self._start = 0
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def clear(self) -> None:
        self._start = self._count = 0

    def append(self, t: float, values: np.ndarray | list[float]) -> None:
        values = np.asarray(values, dtype=float)
        if values.shape != (self.n,):
            raise ValueError(f"expected {self.n} values, got shape {values.shape}")
        cap = len(self._t)
        newest = self._t[(self._start + self._count - 1) % cap] if self._count else -np.inf
        if t < newest - REWIND_S:
            self.clear()
        elif t <= newest:
            return
        i = (self._start + self._count) % cap
        self._t[i] = t
        self._y[i] = values
        if self._count < cap:
            self._count += 1
        else:
            self._start = (self._start + 1) % cap
        while self._count and self._t[self._start] < t - self.window:
            self._start = (self._start + 1) % cap
            self._count -= 1

    def arrays(self) -> tuple[np.ndarray, ...]:
        """(t, channel 0, channel 1, ...) as 1-D arrays, oldest first."""
        idx = (self._start + np.arange(self._count)) % len(self._t)
        return (self._t[idx], *self._y[idx].T)
