"""The realism knobs' ranges, units and meanings (docs/realism.md), defined once: the
`realism` command's struct is built on them here, and lab/realism/knobs.py (the session's
typed configuration and presets) and the page's sliders read them. Standard library only.
"""

from dataclasses import dataclass
from typing import Literal, get_args


@dataclass(frozen=True)
class Knob:
    """One knob's range [lo, hi], unit and meaning; `integer` knobs take whole numbers."""

    lo: float
    hi: float
    unit: str
    meaning: str
    integer: bool = False


KNOBS: dict[str, Knob] = {
    "gyro_noise": Knob(0.0, 0.1, "rad/s/√Hz", "gyro white-noise density"),
    "gyro_bias_walk": Knob(0.0, 0.01, "rad/s²/√Hz", "gyro bias random-walk density"),
    "accel_noise": Knob(0.0, 0.1, "m/s²/√Hz", "accelerometer white-noise density (ekf)"),
    "accel_bias_walk": Knob(0.0, 0.1, "m/s³/√Hz", "accelerometer bias random-walk density (ekf)"),
    "attitude_noise": Knob(0.0, 0.2, "rad", "IMU attitude error per sample (std, each axis)"),
    "base_velocity_noise": Knob(0.0, 1.0, "m/s", "base linear velocity error (std)"),
    "base_position_noise": Knob(0.0, 0.1, "m", "base position error (std)"),
    "encoder_bits": Knob(0, 24, "bits", "encoder resolution per turn (0: exact)", True),
    "encoder_noise": Knob(0.0, 0.01, "rad", "encoder noise before quantization (std)"),
    "velocity_differencing": Knob(0, 1, "0/1", "joint velocities by differencing encoders", True),
    "velocity_filter_hz": Knob(0.0, 1000.0, "Hz", "low-pass on differenced velocity (0: none)"),
    "measurement_delay": Knob(0, 50, "ticks", "age of the state the controller reads", True),
    "command_delay": Knob(0, 50, "ticks", "ticks before a torque command acts", True),
    "torque_bandwidth_hz": Knob(1.0, 1000.0, "Hz", "first-order torque bandwidth (`bandwidth`)"),
    "sea_stiffness": Knob(1.0, 1e5, "N m/rad", "SEA spring stiffness"),
    "sea_motor_inertia": Knob(1e-4, 10.0, "kg m²", "SEA motor inertia through the gear"),
    "sea_kp": Knob(0.0, 1e5, "N m/rad", "SEA motor-side position gain"),
    "sea_kd": Knob(0.0, 1e3, "N m s/rad", "SEA motor-side damping gain"),
    "contact_estimate": Knob(0, 1, "0/1", "touchdown from torques (Raiola eq. 18)", True),
    "torque_saturation": Knob(0.05, 1.0, "× τ_max", "drive torque limit, fraction of the robot's"),
    "coulomb_friction": Knob(0.0, 0.5, "× τ_max", "joint Coulomb friction (MuJoCo frictionloss)"),
    "viscous_friction": Knob(0.0, 0.1, "× τ_max s/rad", "joint viscous friction (dof_damping)"),
    "mass_error": Knob(0.0, 0.5, "fraction", "controller's link masses off by up to ±this"),
    "com_error": Knob(0.0, 0.1, "m", "controller's link CoMs off by up to this, each axis"),
    "seed": Knob(0, 2**63 - 1, "", "seed of every random draw (noise, model error)", True),
}
RealismPreset = Literal["ideal", "typical", "harsh"]
PRESET_NAMES: tuple[str, ...] = get_args(RealismPreset)
Actuator = Literal["ideal", "bandwidth", "sea"]
ACTUATORS: tuple[str, ...] = get_args(Actuator)
# What the controller reads of the base: the (noisy) true state, or the EKF's estimate from the
# IMU and the leg kinematics (lab/estimation, docs/realism.md "The state estimator")
Estimator = Literal["true", "ekf"]
ESTIMATORS: tuple[str, ...] = get_args(Estimator)
PAYLOAD_MASS_MAX = 200.0  # kg, 0 <= payload mass <= max (0 removes it)
PAYLOAD_OFFSET_MAX = 2.0  # m, |x|, |y|, |z| of a payload's offset from its link
