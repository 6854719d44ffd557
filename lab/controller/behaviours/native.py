"""How a behaviour hands its tick to its native twin (cpp/behaviours, bound as lab._kernel).

A behaviour with a twin keeps its Python `update` as the readable reference. On a tick whose
model update the native kernel ran, the twin runs the same steps in C++ in one call: it reads
the Python object's state when it changed since its last call (a Python tick, `configure`, a
request), and writes the state and the references back, so the Python object stays current
and can run the next tick itself. `kernel_ran` says which ran the last update.
"""

from typing import Literal, Protocol

import numpy as np

from lab.controller.model import RobotModel

KernelRan = Literal["native", "python", "none"]  # "none": no update ran yet


class NativeTick(Protocol):
    """A twin's binding (lab._kernel.Walking, BipedStepping, Balance, Squat, Stance)."""

    def update(
        self,
        behaviour: object,
        robot: RobotModel,
        t: float,
        command: np.ndarray,
        touching: np.ndarray,
        reload: bool,
    ) -> None:
        """The behaviour's update in C++ (`reload`: read its state first)."""
        ...


class NativeTwin:
    """The part of a behaviour that hands its tick to a native twin (module docstring): on a
    Python tick through `_native_tick`, and inside the server's one crossing
    (lab/world/native_tick.py), which takes `native_twin()` and reports `native_ran()`."""

    kernel_ran: KernelRan = "none"
    _native: NativeTick | None = None
    _native_stale: bool = True  # the native tick must read this object's state first

    def native_twin(self) -> NativeTick | None:
        """The twin that can run this tick in C++, or None when the Python tick must run."""
        return self._native

    @property
    def native_stale(self) -> bool:
        """Whether the twin must read this object's state before its next tick."""
        return self._native_stale

    def native_ran(self) -> None:
        """The twin ran a tick inside the server's crossing: it holds this object's state."""
        self._native_stale, self.kernel_ran = False, "native"

    def _native_tick(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> bool:
        """Run this tick natively when the twin is built and the native kernel updated the
        model; True when it ran (the Python steps are then skipped)."""
        if self._native is not None and robot.updated_by == "native":
            stale, self._native_stale = self._native_stale, True  # until it ran through
            self._native.update(self, robot, t, command, touching, stale)
            self._native_stale, self.kernel_ran = False, "native"
            return True
        self._native_stale, self.kernel_ran = True, "python"
        return False
