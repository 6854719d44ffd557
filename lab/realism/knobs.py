"""The realism knobs: a typed, range-checked configuration and the presets' loader.

Every knob has a range and a unit (`KNOBS`); `RealismKnobs` holds one value per knob, and
`knobs_from(values)` builds one from a mapping, raising `ValueError` naming the knob and what
was wrong (unknown, wrong type, not finite, out of range) before anything changes. Presets
(`ideal`, `typical`, `harsh`) live in realism/presets.toml with a robot's own overrides and the
source of every value; `preset(name, robot)` loads one. docs/realism.md explains each knob.
The knobs' ranges, units and meanings are the protocol's (lab/protocol/realism.py).
"""

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path

from lab.protocol.realism import ACTUATORS, ESTIMATORS, KNOBS, PRESET_NAMES

PRESETS_PATH = Path(__file__).resolve().parents[2] / "realism" / "presets.toml"


@dataclass(frozen=True)
class RealismKnobs:
    """One value per knob of `KNOBS` (the defaults: an ideal robot), the actuator model
    (`ideal`, `bandwidth` or `sea`) and the state estimator (`true` or `ekf`). `preset` names
    where the values came from."""

    gyro_noise: float = 0.0
    gyro_bias_walk: float = 0.0
    accel_noise: float = 0.0
    accel_bias_walk: float = 0.0
    attitude_noise: float = 0.0
    base_velocity_noise: float = 0.0
    base_position_noise: float = 0.0
    encoder_bits: int = 0
    encoder_noise: float = 0.0
    velocity_differencing: int = 0
    velocity_filter_hz: float = 0.0
    measurement_delay: int = 0
    command_delay: int = 0
    torque_bandwidth_hz: float = 1000.0
    sea_stiffness: float = 1000.0
    sea_motor_inertia: float = 0.01
    sea_kp: float = 0.0
    sea_kd: float = 0.0
    contact_estimate: int = 0
    torque_saturation: float = 1.0
    coulomb_friction: float = 0.0
    viscous_friction: float = 0.0
    mass_error: float = 0.0
    com_error: float = 0.0
    seed: int = 0
    actuator: str = "ideal"
    estimator: str = "true"
    preset: str = "custom"

    def values(self) -> dict[str, float | int | str]:
        """Every knob and the actuator by name (telemetry and `info` report them)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @property
    def model_error(self) -> tuple[float, float, int]:
        """What the controller's model is built with: (mass_error, com_error, seed)."""
        return (self.mass_error, self.com_error, self.seed)


def checked(name: str, raw: object) -> float | int | str:
    """`raw` as the value of knob `name`, or ValueError naming the knob and the problem."""
    choices = {"actuator": ACTUATORS, "estimator": ESTIMATORS}
    if name in choices:
        if raw not in choices[name]:
            raise ValueError(
                f"realism: {name} must be one of {', '.join(choices[name])}, not {raw!r}"
            )
        return str(raw)
    if name not in KNOBS:
        raise ValueError(
            f"realism: unknown knob {name!r} (knobs: {', '.join(KNOBS)}, actuator, estimator)"
        )
    knob = KNOBS[name]
    if isinstance(raw, bool) or not isinstance(raw, int | float):
        raise ValueError(f"realism: {name} must be a number, got {type(raw).__name__}")
    if not math.isfinite(raw):
        raise ValueError(f"realism: {name} must be finite, got {raw}")
    if knob.integer and raw != int(raw):
        raise ValueError(f"realism: {name} must be a whole number, got {raw}")
    if not knob.lo <= raw <= knob.hi:
        raise ValueError(f"realism: {name} = {raw:g} is out of range [{knob.lo:g}, {knob.hi:g}]")
    return int(raw) if knob.integer else float(raw)


def knobs_from(base: RealismKnobs, values: Mapping[str, object]) -> RealismKnobs:
    """`base` with `values` set (every one checked first: a bad one changes nothing)."""
    changes = {name: checked(name, raw) for name, raw in values.items()}
    return replace(base, **changes, preset="custom" if changes else base.preset)


def _presets() -> dict:
    with PRESETS_PATH.open("rb") as file:
        return tomllib.load(file)


def preset(name: str, robot: str) -> RealismKnobs:
    """Preset `name` for `robot`: its general values, then the robot's own (presets.toml)."""
    if name not in PRESET_NAMES:
        raise ValueError(f"realism: unknown preset {name!r} (presets: {', '.join(PRESET_NAMES)})")
    table = _presets().get(name, {})
    values = {k: v for k, v in table.items() if k not in ("robots", "sources")}
    values.update(
        {k: v for k, v in table.get("robots", {}).get(robot, {}).items() if k != "sources"}
    )
    return replace(knobs_from(RealismKnobs(), values), preset=name)


def sources(name: str, robot: str) -> dict[str, str]:
    """Where each value of preset `name` for `robot` comes from (presets.toml's `sources`)."""
    table = _presets().get(name, {})
    return {**table.get("sources", {}), **table.get("robots", {}).get(robot, {}).get("sources", {})}
