"""The `com` scenario metric: how far the centre of mass (centre of gravity) strays from the
reference the controller tracks, the quantity a push-recovery map colours its points by.
"""

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lab.server.session import Session


class ComMetrics:
    """Largest distance of the CoM from its reference (3-D and horizontal), in metres."""

    def __init__(self, session: "Session") -> None:
        self.error = self.horizontal = 0.0

    def update(self, session: "Session") -> None:
        offset = session.model.com - session.controller.references.com
        self.error = max(self.error, float(np.linalg.norm(offset)))
        self.horizontal = max(self.horizontal, float(np.linalg.norm(offset[:2])))

    def result(self) -> dict[str, float]:
        return {"max_com_error_m": self.error, "max_com_horizontal_error_m": self.horizontal}
