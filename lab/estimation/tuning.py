"""The filter's tuning: the noise it assumes (docs/realism.md "The state estimator" says how
these were chosen and what they give).

The densities are those of process.py (continuous, units/√Hz), the kinematics' error and the
initial uncertainty are standard deviations. They are the filter designer's, not the sensors'
(the realism knobs): larger than a datasheet's where the model leaves something out (the
feet's rolling and impacts, the integration of the IMU over a tick).
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class EkfTuning:
    """What the EKF assumes of its sensors and of the feet."""

    accel_noise: float = 0.05  # m/s²/√Hz: accelerometer white noise (and the model's slack)
    gyro_noise: float = 1e-3  # rad/s/√Hz: gyroscope white noise
    accel_bias_walk: float = 1e-3  # m/s³/√Hz
    gyro_bias_walk: float = 1e-4  # rad/s²/√Hz
    foot_slip: float = 0.01  # m/√s: a stance foot's position random walk (Bloesch's w_p)
    kinematics: float = 0.005  # m: a foot's position from the leg kinematics, each axis
    # After any touchdown, for `settle` s, the feet's kinematics count along the vertical with
    # `settling_kinematics` instead: the loading foot's contact sinks and springs back, the
    # unloading ones rise, by up to 5 mm (filter.py says why; docs/realism.md measures it)
    settle: float = 0.2  # s
    settling_kinematics: float = 0.05  # m
    initial_position: float = 1e-3  # m: the start pose is known (the lab's world frame)
    initial_velocity: float = 1e-3  # m/s: the robot starts at rest
    initial_orientation: float = 1e-3  # rad
    initial_accel_bias: float = 0.01  # m/s²
    initial_gyro_bias: float = 0.02  # rad/s: a MEMS gyro's turn-on bias, about 1 °/s
