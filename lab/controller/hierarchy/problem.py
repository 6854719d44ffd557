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
    # (name, number of rows) of each constraint in C, in order: for methods that report
    # rather than enforce inequalities (wbosc).
    constraint_rows: tuple[tuple[str, int], ...] = ()


@dataclass
class DynamicsTerms:
    """The model terms behind the Newton–Euler rows, for methods that change variables.

    M q̈ + h − J_cᵀ F = Sᵀ τ with S = [0 I] selecting the actuated joints; `support` marks the rows
    of F that belong to contacts in support (the others carry no force); `drift` is J̇_c v
    and `transition` the weight w ∈ [0, 1] of each row of F whose contact is being loaded or
    unloaded (NaN: not changing), both for wbosc.
    """

    M: np.ndarray
    h: np.ndarray
    Jc: np.ndarray
    support: np.ndarray
    drift: np.ndarray | None = None
    transition: np.ndarray | None = None


@dataclass
class HierarchyProblem:
    """Find x = [q̈, F] with `dynamics_A x = dynamics_b` exactly, then each level in turn.

    `terms` and `formulation` are optional: `nullspace` reads them, to solve the same
    hierarchy over the variables of Hutter 2014 Tables 1–4 (see hierarchy/formulations.py), and
    `wbosc` needs `terms` for its contact-consistent dynamics.
    """

    dynamics_A: np.ndarray
    dynamics_b: np.ndarray
    levels: list[Level] = field(default_factory=list)
    terms: DynamicsTerms | None = None
    formulation: str = "qdd_force"
    # `nullspace`: the active rows to start each active-set search from (the last tick's
    # `HierarchySolution.active_sets`); any start gives the same optimum, a close one in fewer
    # solves. Ignored where the rows do not match.
    active_start: tuple[list[np.ndarray], ...] = ()
    # `nullspace` (qdd_force): the last tick's x, a point its search may start from as well
    x_start: np.ndarray | None = None

    @property
    def nx(self) -> int:
        """Size of x = [q̈, F]."""
        return int(self.dynamics_A.shape[1])
