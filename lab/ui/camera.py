"""The browser camera following the robot (pure: tested in tests/ui/test_ui_logic.py).

Following puts the camera's target above the base (at the target's height) and moves the camera
with it, keeping the direction and distance the user orbited to, so a trotting robot stays in
view. It is absolute, not a sum of steps: the browser reports its camera back to the UI process
and a report older than the last move must not leave the view behind for good. Re-centring puts
the camera back at the default view of the base.
"""

import numpy as np

DEFAULT_OFFSET = np.array([1.6, -1.6, 0.6])  # m: camera position relative to the base (world)
TARGET_HEIGHT = -0.2  # m: the camera looks at this height relative to the base
FOLLOW_MIN_STEP = 0.02  # m: the target closer than this to the base does not move


def followed(
    position: np.ndarray, look_at: np.ndarray, base: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Camera `position` and `look_at` moved so that the target is above `base` horizontally
    (its height kept: the robot's bobbing does not shake the view); None when it is already
    within FOLLOW_MIN_STEP."""
    position, look_at = np.asarray(position, dtype=float), np.asarray(look_at, dtype=float)
    target = np.array([base[0], base[1], look_at[2]], dtype=float)
    step = target - look_at
    if np.linalg.norm(step) < FOLLOW_MIN_STEP:
        return None
    return position + step, target


def recentred(base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The default view of a base at `base`: camera position and look-at point."""
    base = np.asarray(base, dtype=float)
    return base + DEFAULT_OFFSET, base + np.array([0.0, 0.0, TARGET_HEIGHT])
