"""Click-and-drag push: a spring from the grab point on the body towards the pointer."""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Spring:
    stiffness: float = 400.0  # N/m
    max_force: float = 300.0  # N


def spring_force(grab: np.ndarray, pointer: np.ndarray, spring: Spring) -> np.ndarray:
    """World force k (pointer - grab), its magnitude capped at `spring.max_force`."""
    f = spring.stiffness * (np.asarray(pointer, float) - np.asarray(grab, float))
    norm = float(np.linalg.norm(f))
    if norm > spring.max_force:
        f *= spring.max_force / norm
    return f
