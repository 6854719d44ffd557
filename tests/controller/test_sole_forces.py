"""`sole_forces`: a roll moment goes to load moved between the soles, not to the ankles."""

import numpy as np

from lab.controller.model import BASE_DOF
from lab.controller.tasks import TASK_TYPES
from lab.world.session import Session, SessionConfig

ROLL = 3  # the roll moment's row in the base wrench and in each sole's wrench (sole frame)


def ankle_share_of_a_roll_moment(task: str) -> float:
    """G1 standing: the share of a roll moment on the base that the regularizer `task`, at its
    minimum over the wrenches that give it (G ΔF = [0, 0, 0, M, 0, 0]), puts in the soles' own
    roll torques rather than in vertical load moved from one sole to the other."""
    session = Session(SessionConfig(robot="g1"))
    model, refs = session.model, session.controller.references
    W = TASK_TYPES[task]().rows(model, refs).A[:, model.nv :]
    G = model.Jc[:, :BASE_DOF].T
    moment = np.zeros(BASE_DOF)
    moment[ROLL] = 10.0  # N m
    W_inv = np.linalg.inv(W)
    dF = W_inv @ np.linalg.pinv(G @ W_inv) @ moment
    np.testing.assert_allclose(G @ dF, moment, atol=1e-9)
    ankles = sum(dF[rows.start + ROLL] for rows in model.force_slices)
    return float(ankles / moment[ROLL])


def test_sole_forces_moves_a_roll_moment_into_the_load_difference() -> None:
    # W_F = I: a newton metre costs what a newton does, and with the soles d ≈ 0.12 m each side
    # of the middle the ankles take 1 / (1 + d²) of it (measured 0.986): under a push the 5 cm
    # wide soles' CoPs go to their edges.
    assert ankle_share_of_a_roll_moment("forces") > 0.9
    # Moments in half-sizes of the sole (W = 2.5 cm): 1 / (1 + d² / W²) ≈ 0.04 (measured 0.043).
    assert ankle_share_of_a_roll_moment("sole_forces") < 0.1
