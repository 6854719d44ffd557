"""What the controller knows about one contact: where it is and what it can transmit."""

from dataclasses import dataclass
from typing import Literal

ContactKind = Literal["point", "flat"]


@dataclass(frozen=True)
class ContactSpec:
    """One foot.

    A point foot transmits a 3-D force at `frame` (the centre of the foot sphere); a flat foot
    transmits a 6-D wrench at `frame` (the centre of the sole, z along the sole normal), expressed
    in that frame, whose centre of pressure must stay inside the sole rectangle
    `[-half_length, half_length] x [-half_width, half_width]`.
    """

    name: str
    frame: str
    kind: ContactKind = "point"
    radius: float = 0.0
    half_length: float = 0.0
    half_width: float = 0.0

    @property
    def force_dim(self) -> int:
        """Entries of this contact in F: 3 (force) for a point foot, 6 (wrench) for a flat one."""
        return 3 if self.kind == "point" else 6
