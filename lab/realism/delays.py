"""Delays in whole ticks: ring buffers (cpp/realism/delays.cpp).

A `DelayLine` of d ticks returns, for each value pushed, the one pushed d ticks before; until
d values have passed it returns the first one (a robot at rest before the run started).
"""

import numpy as np


class DelayLine:
    """A fixed-size ring buffer of `ticks` + 1 vectors of `size` floats."""

    def __init__(self, ticks: int, size: int) -> None:
        self.ticks = ticks
        self.buffer = np.zeros((ticks + 1, size))
        self.head = 0
        self.filled = 0

    def reset(self) -> None:
        """Empty: the next value pushed fills the line."""
        self.head = 0
        self.filled = 0

    def push(self, value: np.ndarray) -> np.ndarray:
        """Store `value`; return the value of `ticks` pushes ago (a copy)."""
        if self.ticks == 0:
            return value.copy()
        if self.filled == 0:
            self.buffer[:] = value
        self.buffer[self.head] = value
        self.head = (self.head + 1) % (self.ticks + 1)
        self.filled = min(self.filled + 1, self.ticks + 1)
        return self.buffer[self.head].copy()  # the oldest: written ticks pushes ago
