"""Static crawl of Hutter 2014 §5.1: footfall LH, LF, RH, RF; the CoG always over the support.

Each leg's step has two phases. Shift (all feet down): the CoM moves, on a minimum-jerk path, to
the point nearest to where it is inside the support triangle of the three feet that stay down,
shrunk by a safety margin (so the body moves as little as possible). Swing: the leg follows a
minimum-jerk path to its foothold `step_length` ahead, lifted by a bump of `step_height`, and
touches down at the end of the phase. Base orientation is held level at the initial heading.

The references carry, for the tasks of tasks/objectives.py and tasks/feet.py: the swing
trajectories, the surface normal under each foot (world z, or the known half-cylinder), and the
force interpolation weight w of §5.1.6: a leg is unloaded (w 1 → 0) over the last `transition` s
before lift-off and loaded (w 0 → 1) over the first `transition` s after touchdown.

On a native tick the update runs in C++ (cpp/behaviours/static_walk.cpp; `native.py`).
"""

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lab.controller.behaviours.base import NoOptions
from lab.controller.behaviours.native import NativeTwin
from lab.controller.model import RobotModel
from lab.controller.references import WORLD_UP, WalkReferences
from lab.controller.surfaces import HALF_CYLINDER, HalfCylinder

try:
    from lab._kernel import StaticWalk as NativeStaticWalk
except ImportError:  # the native kernel is not built: every tick runs in Python
    NativeStaticWalk = None

FOOTFALL = ("lh", "lf", "rh", "rf")


@dataclass(frozen=True)
class StaticWalkParameters:
    """Timing and geometry of the static crawl (Hutter 2014 §5.1): per step a CoM shift into
    the next support triangle, then one leg's swing."""

    shift_time: float = 0.8  # s
    swing_time: float = 0.6  # s
    step_length: float = 0.08  # m, along the initial heading
    step_height: float = 0.08  # m
    margin: float = 0.05  # m, CoM inside the support triangle
    transition: float = 0.25  # s, force interpolation ramps

    @property
    def step_time(self) -> float:
        """Duration (s) of one step: the shift, then the swing."""
        return self.shift_time + self.swing_time

    @property
    def cycle_time(self) -> float:
        """Duration (s) of a full cycle: one step per leg."""
        return len(FOOTFALL) * self.step_time


def min_jerk(s: float) -> tuple[float, float, float]:
    """σ(s), σ'(s), σ''(s) of the minimum-jerk profile, s ∈ [0, 1]."""
    s = min(max(s, 0.0), 1.0)
    return (
        10 * s**3 - 15 * s**4 + 6 * s**5,
        30 * s**2 - 60 * s**3 + 30 * s**4,
        60 * s - 180 * s**2 + 120 * s**3,
    )


def bump(s: float) -> tuple[float, float, float]:
    """64 s³(1 − s)³ (peak 1 at s = ½, flat at both ends) and its first two derivatives."""
    s = min(max(s, 0.0), 1.0)
    return (
        64 * s**3 * (1 - s) ** 3,
        192 * s**2 * (1 - s) ** 2 * (1 - 2 * s),
        384 * s * (1 - s) * ((1 - 2 * s) ** 2 - s * (1 - s)),
    )


def inside_triangle(point: np.ndarray, triangle: np.ndarray, margin: float) -> np.ndarray:
    """The point of the triangle shrunk by `margin` nearest to `point` (all 2-D)."""
    centre = triangle.mean(axis=0)
    edges = []  # (unit inward normal, offset): n·p ≥ offset inside
    for a, b in zip(triangle, np.roll(triangle, -1, axis=0), strict=True):
        n = np.array([a[1] - b[1], b[0] - a[0]])
        n /= np.linalg.norm(n)
        if n @ (centre - a) < 0:
            n = -n
        edges.append((n, n @ a + margin))
    if all(n @ point >= c for n, c in edges):
        return point
    # Vertices of the shrunk triangle, then the nearest point on its boundary.
    corners = []
    for k in range(3):
        (n1, c1), (n2, c2) = edges[k - 1], edges[k]
        corners.append(np.linalg.solve(np.vstack([n1, n2]), [c1, c2]))
    best, best_distance = point, np.inf
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        t = np.clip((point - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        candidate = a + t * (b - a)
        distance = np.linalg.norm(candidate - point)
        if distance < best_distance:
            best, best_distance = candidate, distance
    return best


class StaticWalk(NativeTwin, NoOptions):
    """The crawl on flat ground, or in place on a known surface (its normals in the references)."""

    name = "static_walk"
    lifts_feet = True

    def __init__(
        self,
        robot: RobotModel,
        q_standing: np.ndarray,
        parameters: StaticWalkParameters | None = None,
        surface: HalfCylinder | None = None,
    ) -> None:
        self.parameters = parameters or StaticWalkParameters()
        self.surface = surface
        names = [c.name for c in robot.contacts]
        self.order = [names.index(leg) for leg in FOOTFALL]
        n = len(names)
        yaw = pin.rpy.matrixToRpy(robot.base_rotation)[2]
        self.heading = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        self.feet = robot.contact_positions.copy()  # where each foot stands (or will land)
        self.lift_off = self.feet.copy()
        self.com_start = robot.com.copy()
        self.com_target = robot.com.copy()
        self.references = WalkReferences(
            com=robot.com.copy(),
            posture=q_standing[7:].copy(),
            base_height=float(robot.base_position[2]),
            base_rotation=pin.rpy.rpyToMatrix(0.0, 0.0, yaw),
            contact_active=np.ones(n, dtype=bool),
            foot_position=self.feet.copy(),
            foot_velocity=np.zeros((n, 3)),
            foot_acceleration=np.zeros((n, 3)),
            surface_normal=np.array([self._normal(p) for p in self.feet]),
            force_weight=np.full(n, np.nan),
        )
        self.start: float | None = None
        self.step = -1
        self._native = NativeStaticWalk() if NativeStaticWalk is not None else None

    def _normal(self, point: np.ndarray) -> np.ndarray:
        return WORLD_UP if self.surface is None else self.surface.normal(point)

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Advance the crawl to sim time `t` (s): CoM shift, then the step's swing and its
        force interpolation ramps. The command and the measured contacts are not used."""
        if self._native_tick(t, robot, command, touching):
            return
        p, refs = self.parameters, self.references
        if self.start is None:
            self.start = t
        elapsed = t - self.start
        step, into = divmod(elapsed, p.step_time)
        if int(step) != self.step:
            self._begin_step(int(step), robot)
        leg = self.order[self.step % len(self.order)]
        previous = self.order[(self.step - 1) % len(self.order)]
        refs.contact_active[:] = True
        refs.force_weight[:] = np.nan
        if into < p.shift_time:
            s, ds, _ = min_jerk(into / p.shift_time)
            delta = self.com_target - self.com_start
            refs.com = self.com_start + s * delta
            refs.com_velocity = ds * delta / p.shift_time
            if into > p.shift_time - p.transition:
                refs.force_weight[leg] = (p.shift_time - into) / p.transition
            if self.step > 0 and into < p.transition:
                refs.force_weight[previous] = into / p.transition
        else:
            refs.com, refs.com_velocity = self.com_target.copy(), np.zeros(3)
            refs.contact_active[leg] = False
            self._swing(leg, (into - p.shift_time) / p.swing_time)

    def _begin_step(self, step: int, robot: RobotModel) -> None:
        """New step: plan this leg's foothold and the CoM shift over the other three feet."""
        self.step = step
        leg = self.order[step % len(self.order)]
        self.lift_off[leg] = self.feet[leg]
        self.feet[leg] = self.feet[leg] + self.parameters.step_length * self.heading
        stance = [i for i in range(len(self.feet)) if i != leg]
        self.com_start = self.references.com.copy()
        target = inside_triangle(
            self.com_start[:2], self.feet[stance][:, :2], self.parameters.margin
        )
        self.com_target = np.array([target[0], target[1], self.com_start[2]])
        self.references.surface_normal[leg] = self._normal(self.feet[leg])

    def _swing(self, leg: int, s: float) -> None:
        p, refs = self.parameters, self.references
        T = p.swing_time
        a, b = self.lift_off[leg], self.feet[leg]
        m, dm, ddm = min_jerk(s)
        h, dh, ddh = bump(s)
        up = p.step_height * self._normal(a)
        refs.foot_position[leg] = a + m * (b - a) + h * up
        refs.foot_velocity[leg] = (dm * (b - a) + dh * up) / T
        refs.foot_acceleration[leg] = (ddm * (b - a) + ddh * up) / T**2
        if s >= 1.0:
            refs.foot_velocity[leg] = refs.foot_acceleration[leg] = 0.0


class StaticWalkHalfCylinder(StaticWalk):
    """In-place crawl on the half cylinder (Exp8): same footholds, the surface normals known."""

    name = "static_walk_half_cylinder"

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        super().__init__(robot, q_standing, StaticWalkParameters(step_length=0.0), HALF_CYLINDER)
