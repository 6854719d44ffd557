"""Support polygon geometry: the convex hull of the contact points on the ground."""

import numpy as np
from scipy.spatial import ConvexHull, QhullError


def sole_corners(
    position: np.ndarray, rotation: np.ndarray, half_length: float, half_width: float
) -> np.ndarray:
    """The four corners (4, 3) of a flat sole centred at `position` with axes `rotation`."""
    local = np.array(
        [[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]]
    ) * np.array([half_length, half_width, 0.0])
    return np.asarray(position) + local @ np.asarray(rotation).T


def support_polygon(points: np.ndarray) -> np.ndarray:
    """Vertices (k, 3) of the convex hull of `points` (n, 3) in the x-y plane, counter-clockwise.

    Fewer than three points, or collinear points, give the extreme points of the segment (a
    line or a single point): the support polygon degenerates and is drawn as such.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(pts) < 3:
        return pts
    try:
        hull = ConvexHull(pts[:, :2])
    except QhullError:
        direction = pts[:, :2] - pts[0, :2]
        axis = direction[np.argmax(np.linalg.norm(direction, axis=1))]
        s = direction @ axis
        return pts[[int(np.argmin(s)), int(np.argmax(s))]]
    return pts[hull.vertices]


def polygon_bounds(polygon: np.ndarray) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) of a polygon or point set; NaNs when it is empty."""
    if len(polygon) == 0:
        return (float("nan"),) * 4
    return (
        float(polygon[:, 0].min()),
        float(polygon[:, 0].max()),
        float(polygon[:, 1].min()),
        float(polygon[:, 1].max()),
    )
