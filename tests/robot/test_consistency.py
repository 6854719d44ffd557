"""Pinocchio and MuJoCo agree on the rigid-body model of every robot, on random states.

Both engines load the same URDF (lab.description / lab.world.plant); `engine_agreement`
(lab/experiments/robot_check.py, also behind `lab robot check`) maps MuJoCo's velocities onto
pinocchio's and compares mass matrix, bias forces, CoM and the contact frames' placements and
Jacobians.
"""

import pytest

from lab.description import ROBOT_NAMES, load_description
from lab.experiments.robot_check import AGREEMENT_TOL, engine_agreement
from lab.robot import build_robot


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_engines_agree_on_random_states(name: str) -> None:
    # Only round-off is left (measured ≤ 1.6e-15 on every robot): AGREEMENT_TOL says why 1e-12.
    worst = engine_agreement(build_robot(load_description(name)), states=20, seed=7)
    print(name, {k: f"{e:.1e}" for k, e in worst.items()})
    assert max(worst.values()) < AGREEMENT_TOL, worst
