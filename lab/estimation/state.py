"""The filter's nominal state and the layout of its error (Bloesch et al. 2013's state).

x = (p, v, R, d_1 … d_n, b_a, b_g): the base position and linear velocity (world axes), its
orientation R (base → world), each foot's position d_i (world), the accelerometer's and the
gyroscope's biases (base frame). The error δx = (δp, δv, δθ, δd_1 … δd_n, δb_a, δb_g) has
15 + 3n entries, with R = R̂ Exp(δθ) (a local angular error, Solà 2017 §5) and every other
part additive.
"""

from dataclasses import dataclass

import numpy as np


class ErrorLayout:
    """Where each part of δx sits, for `n` feet."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.size = 15 + 3 * n
        self.p, self.v, self.theta = slice(0, 3), slice(3, 6), slice(6, 9)
        self.feet = tuple(slice(9 + 3 * i, 12 + 3 * i) for i in range(n))
        self.accel_bias = slice(9 + 3 * n, 12 + 3 * n)
        self.gyro_bias = slice(12 + 3 * n, 15 + 3 * n)


@dataclass
class NominalState:
    """x̂ of the module docstring (SI units, world axes but for the biases)."""

    position: np.ndarray
    velocity: np.ndarray
    rotation: np.ndarray
    feet: np.ndarray  # (n, 3)
    accel_bias: np.ndarray
    gyro_bias: np.ndarray
