"""The input every hierarchy method takes: hard dynamics rows, then levels of rows."""

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Level:
    """One priority level: weighted equality rows A x = b and inequality rows C x ≤ d.

    `weight` scales the whole level against the others in a weighted (single-QP) method; under
    strict priorities it has no meaning and is ignored.
    """

    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    d: np.ndarray
    weight: float = 1.0


@dataclass
class HierarchyProblem:
    """Find x = [q̈, F] with `dynamics_A x = dynamics_b` exactly, then each level in turn."""

    dynamics_A: np.ndarray
    dynamics_b: np.ndarray
    levels: list[Level] = field(default_factory=list)

    @property
    def nx(self) -> int:
        return self.dynamics_A.shape[1]
