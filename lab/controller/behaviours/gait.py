"""Gait scheduler: when each leg lifts off, swings and lands (Raiola §3.1, Fig. 4–5).

A gait is a timed sequence of lift-offs: each leg lifts off at its phase `offset` of a cycle of
`cycle_time` seconds and may swing for the fraction 1 − duty factor of it. A state machine per
leg keeps stance, swing and reaching (a late touchdown: the swing went past its planned time
without finding the ground). Lift-off is dictated by the schedule; touchdown is haptic: a
swinging foot lands when it touches the ground during the swing-down half (early or on time), or
while reaching.

The clock waits for a late foot: while a leg reaches, the phase does not advance, so the next
group's lift-off comes after that touchdown, never instead of it. Raiola lets a leg swing only
once it has completed a step cycle (Fig. 4); with a running clock, a foot reaching for longer
than the next group's catch-up window (a hind shin caught on a tile edge, blind, reached for
0.12 s) made that group miss its swing, stand a whole extra cycle while the base walked on past
it, and HyQ fell off that diagonal (docs/locomotion.md).

Smooth contact transitions (Hutter §5.1.6, Raiola §4.2): a stance leg is unloaded during the
`ramp_time` before its lift-off and loaded again during the `ramp_time` after its touchdown;
`load(i, t)` is the fraction of full load the leg may carry, for the normal-force bound.

The gait can change at any time (`set_gait`): legs in the air finish their step, and a leg
lifts off only when every leg already in the air (or unloading) belongs to its own lift-off
group in the new gait, so switching never leaves the robot on two legs of the same side.
"""

import enum
import math
from dataclasses import dataclass

LEG_ROLES = ("LF", "RF", "LH", "RH")
CATCH_UP = 0.2  # a leg may still lift off this fraction of its swing window late
MIN_STANCE_RAMPS = 2.0  # a leg stays on the ground at least this many ramp times
REACH_FRACTION = 0.5  # a reaching leg gives up (lands) after this fraction of its swing time


@dataclass(frozen=True)
class GaitPattern:
    """Lift-off phase of each leg role in [0, 1), the duty factor, and a default cycle time in
    units of sqrt(h / g) for a robot whose base stands h above its feet."""

    name: str
    duty_factor: float
    offsets: dict[str, float]
    cycle_periods: float

    def __post_init__(self) -> None:
        if not 0.0 < self.duty_factor < 1.0:
            raise ValueError(f"gait {self.name!r}: duty factor must be in (0, 1)")
        if set(self.offsets) != set(LEG_ROLES):
            raise ValueError(f"gait {self.name!r}: offsets must name the legs {LEG_ROLES}")


GAITS: dict[str, GaitPattern] = {
    # Diagonal pairs; 5 % of the cycle on four legs at each transition (Raiola Fig. 4).
    "trot": GaitPattern("trot", 0.55, {"LF": 0.0, "RH": 0.0, "RF": 0.5, "LH": 0.5}, 2.6),
    # One leg at a time, sequence LH-LF-RH-RF (Raiola Fig. 4).
    "crawl": GaitPattern("crawl", 0.8, {"LH": 0.0, "LF": 0.25, "RH": 0.5, "RF": 0.75}, 6.0),
}


class LegState(enum.Enum):
    """Where a leg is in its cycle: on the ground, in the air, or late and reaching down."""

    STANCE = "stance"
    SWING = "swing"
    REACHING = "reaching"


@dataclass
class Leg:
    """One leg's state machine: its role (LF, RF, LH, RH), state and timings (s, sim time)."""

    role: str
    state: LegState = LegState.STANCE
    since: float = 0.0  # time of the last lift-off or touchdown
    swing_duration: float = 0.0  # planned duration of the current swing
    unload_start: float | None = None  # start of the unloading ramp before lift-off
    last_cycle: int = -1  # cycle index of the last lift-off: one lift-off per cycle


@dataclass(frozen=True)
class LegEvent:
    """A lift-off or touchdown of leg `leg` (index) at sim time `t` (s)."""

    leg: int
    kind: str  # "liftoff" | "touchdown"
    t: float


class GaitScheduler:
    """Per-leg state machines driven by one phase clock; legs are given by role (LF, RF, ...)."""

    def __init__(
        self, roles: tuple[str, ...], gait: GaitPattern, cycle_time: float, t: float
    ) -> None:
        self.legs = [Leg(role, since=t - 1.0) for role in roles]
        self.gait = gait
        self.cycle_time = cycle_time
        # Start so that the first lift-off comes after a full unloading ramp.
        self.phase = -2.0 * self.ramp_time / cycle_time
        self.t = t

    @property
    def ramp_time(self) -> float:
        """Duration (s) of the load ramps before lift-off and after touchdown."""
        return 0.05 * self.cycle_time

    @property
    def swing_time(self) -> float:
        """Planned time (s) a foot is in the air each cycle."""
        return (1.0 - self.gait.duty_factor) * self.cycle_time

    def set_gait(self, gait: GaitPattern, cycle_time: float) -> None:
        """Change gait or cycle time in stride; legs in the air keep their current swing."""
        if not cycle_time > 0.0:
            raise ValueError(f"cycle time must be > 0 s, got {cycle_time}")
        self.gait, self.cycle_time = gait, cycle_time

    def _local(self, leg: Leg) -> tuple[int, float]:
        """Cycle index and phase of `leg` within its own cycle (0 = scheduled lift-off)."""
        shifted = self.phase - self.gait.offsets[leg.role]
        cycle = math.floor(shifted)
        return cycle, shifted - cycle

    def _may_unload(self, i: int) -> bool:
        """Every other leg in the air or unloading lifts off together with leg i."""
        offset = self.gait.offsets[self.legs[i].role]
        return all(
            (other.state is LegState.STANCE and other.unload_start is None)
            or self.gait.offsets[other.role] == offset
            for j, other in enumerate(self.legs)
            if j != i
        )

    def advance(self, t: float, touching: list[bool] | tuple[bool, ...]) -> list[LegEvent]:
        """Move the clock to time t and every leg's state machine; return lift-offs/touchdowns.
        The clock stands still while a leg reaches (module docstring)."""
        if not any(leg.state is LegState.REACHING for leg in self.legs):
            self.phase += (t - self.t) / self.cycle_time
        self.t = t
        events = []
        stance = [leg.state is LegState.STANCE for leg in self.legs]
        # Touchdowns first, so that every lift-off this tick sees the same legs on the ground.
        for i, (leg, touch) in enumerate(zip(self.legs, touching, strict=True)):
            if stance[i]:
                continue
            elapsed = t - leg.since
            landed = touch and elapsed >= 0.5 * leg.swing_duration
            gave_up = elapsed >= (1.0 + REACH_FRACTION) * leg.swing_duration
            if landed or gave_up:
                leg.state, leg.since = LegState.STANCE, t
                events.append(LegEvent(i, "touchdown", t))
            elif elapsed >= leg.swing_duration:
                leg.state = LegState.REACHING
        for i in range(len(self.legs)):
            if stance[i] and self._liftoff(i, t):
                events.append(LegEvent(i, "liftoff", t))
        return events

    def _liftoff(self, i: int, t: float) -> bool:
        """Unload a stance leg ahead of its scheduled lift-off, and lift it once unloaded."""
        leg = self.legs[i]
        cycle, local = self._local(leg)
        time_to_liftoff = (1.0 - local) * self.cycle_time
        window = 1.0 - self.gait.duty_factor
        ramp = self.ramp_time
        if leg.unload_start is None:
            due = local < CATCH_UP * window and cycle > leg.last_cycle
            rested = t - leg.since >= MIN_STANCE_RAMPS * ramp
            soon = time_to_liftoff <= ramp or due
            if rested and soon and self._may_unload(i):
                leg.unload_start = t
            return False
        if t - leg.unload_start < ramp - 1e-9:
            return False
        # Unloaded: lift off now and swing to the end of this leg's swing window.
        if local >= window:  # unloaded ahead of the window: that is its next cycle
            cycle, local = cycle + 1, 0.0
        leg.state, leg.since, leg.unload_start, leg.last_cycle = LegState.SWING, t, None, cycle
        leg.swing_duration = max((window - local) * self.cycle_time, 0.5 * self.swing_time)
        return True

    def load(self, i: int, t: float) -> float:
        """Fraction of full load leg i may carry: 0 in the air, ramps at both ends of stance."""
        leg = self.legs[i]
        if leg.state is not LegState.STANCE:
            return 0.0
        ramp = self.ramp_time
        up = (t - leg.since) / ramp
        down = 1.0 if leg.unload_start is None else 1.0 - (t - leg.unload_start) / ramp
        return min(1.0, max(0.0, min(up, down)))

    def take_state(self, other: "GaitScheduler") -> None:
        """Continue from another scheduler (same legs): leg states and clock, not the gait."""
        self.legs = [Leg(**vars(leg)) for leg in other.legs]
        self.phase, self.t = other.phase, other.t
