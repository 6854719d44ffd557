"""The EKF alone (lab/estimation) on a synthetic case with a known answer: ANYmal standing
still at its standing posture, its IMU and encoders read with noise and a gyro bias, the
filter told that the diagonal pairs of feet take turns to swing (as in a trot)."""

import math

import numpy as np
import pinocchio as pin

from lab.description import load_description
from lab.estimation.filter import LeggedEkf
from lab.estimation.measurement import LegKinematics
from lab.robot import build_robot

DT = 1e-3
GYRO_BIAS = np.array([0.01, -0.02, 0.005])  # rad/s, constant
ACCEL_WHITE = 6e-4 / math.sqrt(DT)  # m/s² per sample: a 60 µg/√Hz accelerometer
GYRO_WHITE = 1.745e-4 / math.sqrt(DT)  # rad/s per sample: 0.01 °/s/√Hz
ENCODER_NOISE = 1e-4  # rad per sample


def _standing_filter() -> tuple[np.ndarray, LeggedEkf]:
    robot = build_robot(load_description("anymal"))
    kinematics = LegKinematics(robot.model, [contact.frame for contact in robot.contacts])
    radii = np.array([contact.radius for contact in robot.contacts])
    ekf = LeggedEkf(kinematics, radii, np.array(robot.model.gravity.linear), DT)
    ekf.reset(robot.q_standing, np.zeros(robot.model.nv))
    return robot.q_standing, ekf


def _trot_contacts(k: int) -> np.ndarray:
    """LF+RH, then RF+LH, 0.25 s each, all four for the first 0.5 s (feet lf, rf, lh, rh)."""
    if k < 500:
        return np.ones(4, dtype=bool)
    first = (k // 250) % 2 == 0
    return np.array([first, not first, not first, first])


def test_a_standing_robot_estimate_converges_and_its_covariance_stays_bounded() -> None:
    """Started 5 cm/s off in velocity, with a gyro bias of up to 1.1 °/s (within the filter's
    prior), the estimate converges to rest within 5 mm/s; roll and pitch stay within 2 mrad
    (the accelerometer sees gravity), the gyro's roll and pitch biases are found within
    2 mrad/s; the position drifts less than 1 cm (unobservable, but held by the feet); the yaw
    no faster than the gyro's z bias; and the covariance stays symmetric, positive definite,
    with the velocity's and the tilt's standard deviations bounded and not growing over the
    last 4 s."""
    q, ekf = _standing_filter()
    rng = np.random.default_rng(3)
    gravity = ekf.gravity
    ekf.x.velocity += np.array([0.05, -0.03, 0.02])
    joints = q[7:]
    layout = ekf.layout
    deviations = []
    for k in range(6000):
        accel = -gravity + ACCEL_WHITE * rng.standard_normal(3)  # upright: R = I
        gyro = GYRO_BIAS + GYRO_WHITE * rng.standard_normal(3)
        ekf.step(
            accel,
            gyro,
            joints + ENCODER_NOISE * rng.standard_normal(joints.size),
            np.zeros(joints.size),
            _trot_contacts(k),
        )
        if k in (1999, 5999):
            deviations.append(np.sqrt(np.diag(ekf.P)))
    x = ekf.x
    assert np.linalg.norm(x.velocity) < 0.005
    rpy = pin.rpy.matrixToRpy(x.rotation)
    assert np.all(np.abs(rpy[:2]) < 0.002)
    assert abs(rpy[2]) <= GYRO_BIAS[2] * 6.0
    np.testing.assert_allclose(x.gyro_bias[:2], GYRO_BIAS[:2], atol=0.002)
    assert np.linalg.norm(x.position - q[:3]) < 0.01
    P = ekf.P
    np.testing.assert_allclose(P, P.T, atol=1e-15)
    assert np.linalg.eigvalsh(P).min() > 0.0
    early, late = deviations
    assert np.all(late[layout.v] < 0.05) and np.all(late[layout.theta][:2] < 0.005)
    assert np.all(late[layout.v] <= 1.1 * early[layout.v])
    assert np.all(late[layout.theta][:2] <= 1.1 * early[layout.theta][:2])


def test_a_foot_touches_down_where_the_kinematics_put_it() -> None:
    """A foot the filter is told swings, then touches down elsewhere: its position in the
    state is p̂ + R̂ s̃ of the kinematics at the touchdown (within that tick's correction,
    1 mm), not where it lifted off."""
    q, ekf = _standing_filter()
    gravity = ekf.gravity
    joints = q[7:].copy()
    contacts = np.ones(4, dtype=bool)
    for _ in range(100):
        ekf.step(-gravity, np.zeros(3), joints, np.zeros(joints.size), contacts)
    contacts[0] = False
    for _ in range(100):
        ekf.step(-gravity, np.zeros(3), joints, np.zeros(joints.size), contacts)
    before = ekf.x.feet[0].copy()
    joints[:3] += 0.05  # the swinging leg lands elsewhere (the first three joints are LF's)
    contacts[0] = True
    ekf.step(-gravity, np.zeros(3), joints, np.zeros(joints.size), contacts)
    landed = ekf.x.position + ekf.x.rotation @ ekf.kinematics.feet(joints)[0]
    np.testing.assert_allclose(ekf.x.feet[0], landed, atol=1e-3)
    assert np.linalg.norm(ekf.x.feet[0] - before) > 0.01  # it moved with the leg
