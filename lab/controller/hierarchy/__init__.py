"""Hierarchy methods: same input (HierarchyProblem), same output (HierarchySolution: x = [q̈, F]
with each level's status, residual and solve time)."""

from collections.abc import Callable, Iterable

from lab.controller.hierarchy.cascade import solve_cascade
from lab.controller.hierarchy.nullspace import solve_nullspace
from lab.controller.hierarchy.problem import HierarchyProblem, Level
from lab.controller.hierarchy.solution import HierarchySolution
from lab.controller.hierarchy.wbosc import check_stack as wbosc_check_stack
from lab.controller.hierarchy.wbosc import solve_wbosc
from lab.controller.hierarchy.weighted import solve_weighted

HierarchyMethod = Callable[[HierarchyProblem, str], HierarchySolution]

METHODS: dict[str, HierarchyMethod] = {
    "cascade": solve_cascade,
    "weighted": solve_weighted,
    "nullspace": solve_nullspace,
    "wbosc": solve_wbosc,
}

# The methods that solve QPs with the configured solver (nullspace and wbosc solve none), and the
# one whose decision variable the formulation picks (the others compute x = [q̈, F]).
QP_METHODS = ("cascade", "weighted")
FORMULATION_METHODS = ("nullspace",)
NO_SOLVER = "none"  # what ran as the solver of a method that solves no QP

# A method that cannot realize every task says which before it runs: raises ValueError naming them.
STACK_CHECKS: dict[str, Callable[[Iterable[str]], None]] = {"wbosc": wbosc_check_stack}

__all__ = [
    "FORMULATION_METHODS",
    "METHODS",
    "NO_SOLVER",
    "QP_METHODS",
    "STACK_CHECKS",
    "HierarchyMethod",
    "HierarchyProblem",
    "HierarchySolution",
    "Level",
]
