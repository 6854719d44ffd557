"""Known terrain geometry the controller may use (pure: shared by scenes and behaviours).

`HALF_CYLINDER` is the curved surface of Hutter 2014 §5.1.5 (Exp8): a cylinder lying along world
x whose top bulges between the feet, sized so that ANYmal's standing feet (y = ±0.251 m, foot
sphere radius 0.03 m) rest on it exactly, on slopes of SLOPE rad to either side.
"""

from dataclasses import dataclass

import numpy as np

ANYMAL_FOOT_Y = 0.251
ANYMAL_FOOT_RADIUS = 0.03
SLOPE = np.radians(30.0)


@dataclass(frozen=True)
class HalfCylinder:
    """A cylinder of `radius` with its axis along world x at height `axis_height` (y = 0)."""

    radius: float
    axis_height: float

    def normal(self, point: np.ndarray) -> np.ndarray:
        """Outward unit normal of the surface nearest `point` (world)."""
        n = np.array([0.0, point[1], point[2] - self.axis_height])
        unit: np.ndarray = n / np.linalg.norm(n)
        return unit


def _sized_for_anymal() -> HalfCylinder:
    reach = ANYMAL_FOOT_Y / np.sin(SLOPE)  # axis to foot-sphere centre
    axis_height = ANYMAL_FOOT_RADIUS - reach * np.cos(SLOPE)
    return HalfCylinder(radius=float(reach - ANYMAL_FOOT_RADIUS), axis_height=float(axis_height))


HALF_CYLINDER = _sized_for_anymal()
