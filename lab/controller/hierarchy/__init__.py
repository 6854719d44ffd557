"""Hierarchy methods: same input (HierarchyProblem), same output (HierarchySolution: x = [q̈, F]
with each level's status, residual and solve time)."""

from collections.abc import Callable

from lab.controller.hierarchy.cascade import solve_cascade
from lab.controller.hierarchy.nullspace import solve_nullspace
from lab.controller.hierarchy.problem import HierarchyProblem, Level
from lab.controller.hierarchy.solution import HierarchySolution
from lab.controller.hierarchy.weighted import solve_weighted

HierarchyMethod = Callable[[HierarchyProblem, str], HierarchySolution]

METHODS: dict[str, HierarchyMethod] = {
    "cascade": solve_cascade,
    "weighted": solve_weighted,
    "nullspace": solve_nullspace,
}

__all__ = ["METHODS", "HierarchyMethod", "HierarchyProblem", "HierarchySolution", "Level"]
