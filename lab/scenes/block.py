"""A block under Talos's left sole: non-coplanar feet (Herzog 2016 §5.2, "one foot was put on top
of a block").

A box HEIGHT high whose top holds the whole left sole of Talos's standing posture (sole centre at
y = 0.085 m, half width 0.067 m) and stops at y = GAP, clear of the right sole (whose inner edge is
at y = −0.018 m). The robot starts with that foot raised by HEIGHT onto it (`START_RISE` in
`lab.scenes`); the scene is made for Talos's feet only (`SCENE_ROBOTS`).
"""

from lab.scenes.flat import flat
from lab.scenes.geometry import TerrainGeom

HEIGHT = 0.04  # m
GAP = 0.005  # m, y of the block's inner side
HALF_LENGTH = 0.25  # m along x
WIDTH = 0.3  # m along y


def block() -> tuple[TerrainGeom, ...]:
    return (
        *flat(),
        TerrainGeom(
            "block",
            "box",
            (HALF_LENGTH, 0.5 * WIDTH, 0.5 * HEIGHT),
            (0.0, GAP + 0.5 * WIDTH, 0.5 * HEIGHT),
        ),
    )
