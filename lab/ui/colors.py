"""Colour maps for overlays."""

import numpy as np


def friction_usage(force: np.ndarray, normal: np.ndarray, mu: float) -> float:
    """|f_t| / (mu f_n) for a contact force and the unit surface normal; inf when f_n <= 0."""
    fn = float(np.dot(force, normal))
    if fn <= 0.0:
        return float("inf")
    ft = np.linalg.norm(np.asarray(force) - fn * np.asarray(normal))
    return float(ft / (mu * fn))


_STOPS = np.array([[0.1, 0.75, 0.2], [0.95, 0.8, 0.1], [0.9, 0.1, 0.1]])


def usage_colour(usage: float) -> tuple[int, int, int]:
    """Green at 0, yellow at 0.5, red at 1 and beyond (friction cone edge), as 0-255 RGB."""
    u = 1.0 if not np.isfinite(usage) else min(max(usage, 0.0), 1.0)
    x = u * (len(_STOPS) - 1)
    i = min(int(x), len(_STOPS) - 2)
    rgb = _STOPS[i] + (x - i) * (_STOPS[i + 1] - _STOPS[i])
    r, g, b = (round(float(c) * 255) for c in rgb)
    return (r, g, b)
