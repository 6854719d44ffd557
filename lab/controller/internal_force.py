"""Internal forces between point contacts (Kim 2016 §IV, eqs. 14–17; Sentis 2010).

For a pair of point feet a, b the internal force is the tension along the line between them:
F_int = x̂ᵀ (λ_b − λ_a) with x̂ = (p_b − p_a)/‖p_b − p_a‖ (eq. 14: W_int = S_t R_t Δ_t, whose
selection S_t keeps the first row of R_t, x̂ᵀ). λ is the force a foot exerts on the environment,
so F_int > 0 when the feet push apart (Kim's 100 N "pushing outwards"). With n point feet in
support every pair gives one row (n(n − 1)/2 of them; for n ≤ 3 that is the 3n − 6 internal
dimensions, for a biped one). In the lab's convention F = −λ is the force on the robot.
"""

import itertools

import numpy as np


def internal_force_map(positions: np.ndarray) -> np.ndarray:
    """W_int (n_pairs × 3n) over the forces on the environment λ = [λ_1; …; λ_n] of n point
    contacts at `positions` (n × 3, world): one row x̂ᵀ (λ_b − λ_a) per pair a < b."""
    n = len(positions)
    pairs = list(itertools.combinations(range(n), 2))
    W = np.zeros((len(pairs), 3 * n))
    for row, (a, b) in enumerate(pairs):
        line = positions[b] - positions[a]
        x_hat = line / np.linalg.norm(line)  # R_t's first row (eq. 16)
        W[row, 3 * b : 3 * b + 3] = x_hat  # Δ_t = (I −I) (eq. 17)
        W[row, 3 * a : 3 * a + 3] = -x_hat
    return W


def internal_forces(positions: np.ndarray, forces_on_robot: np.ndarray) -> np.ndarray:
    """F_int = W_int λ (eq. 41) from the forces on the robot (n × 3, world) at `positions`."""
    forces: np.ndarray = internal_force_map(positions) @ -np.asarray(forces_on_robot).reshape(-1)
    return forces
