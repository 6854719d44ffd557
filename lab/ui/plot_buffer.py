"""Rolling time-series buffers for the live plots."""

import numpy as np


class RollingBuffer:
    """The last `window` seconds of `n` channels sampled at irregular times.

    Appending a time earlier than the newest sample (a reset rewound the clock) clears the buffer.
    Storage is a fixed ring of `capacity` samples, so memory does not grow.
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
        if self._count and t < self._t[(self._start + self._count - 1) % cap]:
            self.clear()
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
