"""The records a payload or a robot description carries: `ContactSpec` (one foot) and
`TaskGains` (kp, kd, weight of a task). Plain frozen dataclasses (the controller builds and
replaces them); standard library only."""

from dataclasses import dataclass
from typing import Literal

ContactKind = Literal["point", "flat"]


@dataclass(frozen=True)
class ContactSpec:
    """One foot.

    A point foot transmits a 3-D force at `frame` (the centre of the foot sphere); a flat foot
    transmits a 6-D wrench at `frame` (the centre of the sole, z along the sole normal), expressed
    in that frame, whose centre of pressure must stay inside the sole rectangle
    `[-half_length, half_length] x [-half_width, half_width]` (m).
    """

    name: str
    frame: str
    kind: ContactKind = "point"
    radius: float = 0.0
    half_length: float = 0.0
    half_width: float = 0.0

    @property
    def force_dim(self) -> int:
        """Rows of the contact's force in x = [q̈, F]: 3 (point) or 6 (flat)."""
        return 3 if self.kind == "point" else 6


@dataclass(frozen=True)
class TaskGains:
    """PD gains (kp in 1/s², kd in 1/s for motion tasks) and the weight of a task inside its
    level (unused fields keep their defaults)."""

    kp: float = 0.0
    kd: float = 0.0
    weight: float = 1.0
