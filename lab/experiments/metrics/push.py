"""The `pushes` metric: Herzog 2016 Table 3's numbers for each push of a scenario.

A push's window runs from the tick it starts to the start of the next push (or the end of the
run). For each push i it reports `push<i>_peak_force_n` and `push<i>_impulse_ns` (the applied
force is constant over its duration), the largest CoG error |c − c_ref| (m), the largest linear
(kg m/s) and angular (kg m²/s, about the CoG) momentum in the window, and `push<i>_fell`
(1 when the robot fell in it); and over all pushes the largest CoG error and the number of
falls.
"""

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lab.world.session import Session
    from lab.world.session_base import Push


@dataclass
class PushWindow:
    """One push and the worst the robot did until the next."""

    peak_force: float
    impulse: float
    cog_error: float = 0.0
    linear_momentum: float = 0.0
    angular_momentum: float = 0.0
    fell: bool = False


class PushMetrics:
    def __init__(self, session: "Session") -> None:
        self.windows: list[PushWindow] = []
        self._seen: set[tuple[str, float]] = set()

    def update(self, session: "Session") -> None:
        for push in session.pushes.values():
            key = (push.body, push.ends_at)
            if key not in self._seen:
                self._seen.add(key)
                # It began at the start of this tick.
                start = session.time - session.config.timestep
                self.windows.append(_window(push, start))
        if not self.windows:
            return
        window = self.windows[-1]
        model = session.model
        # each norm as np.linalg.norm computes it, sqrt(x.dot(x)), without its checks (3 µs each)
        h = model.centroidal_momentum()
        linear, angular = h[:3], h[3:]
        error = model.com - session.controller.references.com
        window.cog_error = max(window.cog_error, math.sqrt(error.dot(error)))
        window.linear_momentum = max(window.linear_momentum, math.sqrt(linear.dot(linear)))
        window.angular_momentum = max(window.angular_momentum, math.sqrt(angular.dot(angular)))
        window.fell = window.fell or session.fell

    def result(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for i, w in enumerate(self.windows):
            out |= {
                f"push{i}_peak_force_n": w.peak_force,
                f"push{i}_impulse_ns": w.impulse,
                f"push{i}_max_cog_error_m": w.cog_error,
                f"push{i}_max_linear_momentum": w.linear_momentum,
                f"push{i}_max_angular_momentum": w.angular_momentum,
                f"push{i}_fell": float(w.fell),
            }
        out["pushes_max_cog_error_m"] = max((w.cog_error for w in self.windows), default=0.0)
        out["pushes_fell"] = float(sum(w.fell for w in self.windows))
        return out


def _window(push: "Push", start: float) -> PushWindow:
    """The window of a push applied from `start` to `push.ends_at` (s)."""
    force = float(np.linalg.norm(push.force))
    return PushWindow(force, force * (push.ends_at - start))
