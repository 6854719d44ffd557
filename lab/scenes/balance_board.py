"""A board on a beam that tilts in [TILT_MIN, TILT_MAX] = [−2.8°, 5.6°] (Herzog 2016 §5.2.3,
Fig. 9), the board motion in the sagittal plane (`balance_board`) or the lateral one
(`balance_board_lateral`).

The beam (the hinge, limited to the paper's range) lies ARM from the robot's standing place, the
length that turns the paper's range into its 6.9 cm of elevation; the board's top is at z = 0
when level, so the robot starts standing on it. A script varies the slope through the range
(smooth steps between WAYPOINTS), holds the board at its highest tilt and lets go at DROP: the
board, loaded by the robot, falls until the hinge's lower limit stops it (the paper's drop "from
the maximum height" onto the ground). The board hits no other terrain.
"""

from itertools import pairwise
from typing import Literal

import numpy as np

from lab.scenes.geometry import MovingBody, SceneJoint, TerrainGeom, box_inertia

TILT_MIN, TILT_MAX = np.radians(-2.8), np.radians(5.6)
ARM = 0.069 / (np.sin(TILT_MAX) - np.sin(TILT_MIN))  # m, beam to robot: 0.47
THICKNESS = 0.04  # m
BEHIND = 0.1  # m, board beyond the beam
AHEAD = 0.6  # m, board beyond the robot's standing place
HALF_WIDTH = 0.5  # m
MASS = 15.0  # kg
FLOOR_DEPTH = 0.15  # m below the level board's top
# (sim time s, tilt rad): level, down to the lowest tilt, up to the highest, held there
WAYPOINTS = ((0.0, 0.0), (0.3, 0.0), (0.8, TILT_MIN), (1.8, TILT_MAX), (2.0, TILT_MAX))
DROP = WAYPOINTS[-1][0]  # s, the board is let go


def board_tilt(t: float) -> tuple[float, ...] | None:
    """The board's tilt (rad, positive raises the robot) at sim time `t` (s); None from DROP on."""
    if t >= DROP:
        return None
    for (t0, a0), (t1, a1) in pairwise(WAYPOINTS):
        if t < t1:
            s = 0.5 * (1.0 - np.cos(np.pi * (max(t, t0) - t0) / (t1 - t0)))
            return (float(a0 + s * (a1 - a0)),)
    return (float(WAYPOINTS[-1][1]),)


def _board(plane: Literal["sagittal", "lateral"]) -> MovingBody:
    length = BEHIND + ARM + AHEAD
    middle = 0.5 * length - BEHIND  # along the board from the beam
    if plane == "sagittal":  # beam along y behind the robot; tilting raises the robot's side
        pivot, axis = (-ARM, 0.0, -0.5 * THICKNESS), (0.0, -1.0, 0.0)
        half, centre = (0.5 * length, HALF_WIDTH, 0.5 * THICKNESS), (middle, 0.0, 0.0)
    else:  # beam along x on the robot's right
        pivot, axis = (0.0, -ARM, -0.5 * THICKNESS), (1.0, 0.0, 0.0)
        half, centre = (HALF_WIDTH, 0.5 * length, 0.5 * THICKNESS), (0.0, middle, 0.0)
    return MovingBody(
        "board",
        pivot,
        (TerrainGeom("board", "box", half, centre),),
        (SceneJoint("hinge", axis, (float(TILT_MIN), float(TILT_MAX))),),
        board_tilt,
        MASS,
        box_inertia(MASS, half),
        centre,
    )


def _floor() -> tuple[TerrainGeom, ...]:
    return (TerrainGeom("floor", "plane", (0.0, 0.0, 1.0), (0.0, 0.0, -FLOOR_DEPTH)),)


def balance_board() -> tuple[TerrainGeom, ...]:
    return _floor()


def balance_board_bodies() -> tuple[MovingBody, ...]:
    return (_board("sagittal"),)


def balance_board_lateral_bodies() -> tuple[MovingBody, ...]:
    return (_board("lateral"),)
