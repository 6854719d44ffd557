"""Hierarchy methods: same input (HierarchyProblem), same output (x = [q̈, F])."""

from collections.abc import Callable

import numpy as np

from lab.controller.hierarchy.cascade import solve_cascade
from lab.controller.hierarchy.nullspace import solve_nullspace
from lab.controller.hierarchy.problem import HierarchyProblem, Level
from lab.controller.hierarchy.weighted import solve_weighted

HierarchyMethod = Callable[[HierarchyProblem, str], np.ndarray]

METHODS: dict[str, HierarchyMethod] = {
    "cascade": solve_cascade,
    "weighted": solve_weighted,
    "nullspace": solve_nullspace,
}

__all__ = ["METHODS", "HierarchyMethod", "HierarchyProblem", "Level"]
