"""A platform under both feet that a script rolls, pitches, turns and shifts (Herzog 2016 §5.2.3,
Fig. 8: "we put the biped on a rolling platform and rotated and moved it").

The platform's top face is at z = 0 at rest, so the robot starts standing on it; the floor lies
DEPTH below. Its pose follows smooth sums of sines in sim time, faded in over RAMP seconds (pose
and velocity zero at t = 0): a few centimetres along y (the paper's platform moved along Y, the
robot facing it), less along x and z, a few degrees of roll, pitch and yaw. The sim holds each of
its six joints to the script with a soft equality constraint, so the platform has real velocities
and carries the soles by MuJoCo's friction.
"""

import numpy as np

from lab.scenes.flat import flat
from lab.scenes.geometry import MovingBody, SceneJoint, TerrainGeom, box_inertia

HALF_SIZE = (0.6, 0.5, 0.04)  # m
DEPTH = 0.3  # m, floor below the platform's top
MASS = 40.0  # kg
RAMP = 1.0  # s
# (amplitude, frequency Hz) per joint: x, y, z (m), yaw, pitch, roll (rad)
MOTION = (
    (0.02, 0.3),
    (0.04, 0.5),
    (0.01, 0.4),
    (np.radians(5.0), 0.25),
    (np.radians(2.0), 0.35),
    (np.radians(3.0), 0.45),
)
JOINTS = (
    SceneJoint("slide", (1.0, 0.0, 0.0)),
    SceneJoint("slide", (0.0, 1.0, 0.0)),
    SceneJoint("slide", (0.0, 0.0, 1.0)),
    SceneJoint("hinge", (0.0, 0.0, 1.0)),
    SceneJoint("hinge", (0.0, 1.0, 0.0)),
    SceneJoint("hinge", (1.0, 0.0, 0.0)),
)


def platform_pose(t: float) -> tuple[float, ...]:
    """The platform's joint targets at sim time `t` (s): x, y, z (m), yaw, pitch, roll (rad)."""
    fade = 0.5 * (1.0 - np.cos(np.pi * min(max(t, 0.0), RAMP) / RAMP))
    return tuple(float(fade * a * np.sin(2.0 * np.pi * f * t)) for a, f in MOTION)


def platform() -> tuple[TerrainGeom, ...]:
    floor = flat()[0]
    return (TerrainGeom(floor.name, floor.shape, floor.size, (0.0, 0.0, -DEPTH)),)


def platform_bodies() -> tuple[MovingBody, ...]:
    top = TerrainGeom("platform", "box", HALF_SIZE, (0.0, 0.0, -HALF_SIZE[2]))
    return (
        MovingBody(
            "platform",
            (0.0, 0.0, 0.0),
            (top,),
            JOINTS,
            platform_pose,
            MASS,
            box_inertia(MASS, HALF_SIZE),
            top.position,
        ),
    )
