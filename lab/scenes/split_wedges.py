"""Two 45° wedges angled inwards under Bolt's feet: Kim 2016 Fig. 6 (a convex "basin").

Each wedge is a thin box whose top face tilts 45° about x, rising outwards, with Bolt's standing
foot sphere touching it; the two faces meet in a V along x under the robot. On such a slope a
foot that presses only downwards slips (tan 45° = 1 > μ = 0.8): Bolt stands only when its feet
push outwards hard enough, with the internal force (Kim §VI-A). A floor lies under the V.
"""

import numpy as np

from lab.scenes.geometry import TerrainGeom

ANGLE = np.radians(45.0)
# Bolt's standing foot-sphere centres (m, world; robots/bolt.toml's standing posture) and radius:
# the wedges are placed for them (tests/controller/test_kim_wedges.py checks it).
FOOT_X = -0.0213
FOOT_Y = 0.02607
FOOT_Z = 0.01677
FOOT_RADIUS = 0.016
LENGTH = 0.6  # m along x
OUTER = 0.25  # m along the face beyond the foot
THICKNESS = 0.05  # m


def wedge_normal(side: int) -> np.ndarray:
    """The top face's normal of the wedge under the left (side = +1) or right (−1) foot."""
    return np.array([0.0, -side * np.sin(ANGLE), np.cos(ANGLE)])


def split_wedges() -> tuple[TerrainGeom, ...]:
    geoms = []
    bottom_z = 0.0
    for side, name in ((1, "left_wedge"), (-1, "right_wedge")):
        normal = wedge_normal(side)
        up_face = np.array([0.0, side * np.cos(ANGLE), np.sin(ANGLE)])  # outwards, up
        touch = np.array([FOOT_X, side * FOOT_Y, FOOT_Z]) - FOOT_RADIUS * normal
        inner = abs(touch[1]) / np.cos(ANGLE)  # along the face from the touch point to y = 0
        bottom_z = float(touch[2] - inner * np.sin(ANGLE))
        middle = touch + 0.5 * (OUTER - inner) * up_face - 0.5 * THICKNESS * normal
        half = 0.5 * side * ANGLE  # a rotation about x by ±45°
        geoms.append(
            TerrainGeom(
                name,
                "box",
                (0.5 * LENGTH, 0.5 * (OUTER + inner), 0.5 * THICKNESS),
                (float(middle[0]), float(middle[1]), float(middle[2])),
                (float(np.cos(half)), float(np.sin(half)), 0.0, 0.0),
            )
        )
    floor = TerrainGeom("floor", "plane", (0.0, 0.0, 1.0), (0.0, 0.0, bottom_z - 0.05))
    return (floor, *geoms)
