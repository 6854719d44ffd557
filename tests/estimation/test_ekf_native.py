"""The EKF's two kernels agree: lab/estimation with lab/realism/accelerometer.py in Python and
cpp/estimation with cpp/realism/accelerometer.cpp (lab._kernel's EkfEstimator), fed the same
recorded trot (the true state, the realism layer's measured state with its noise, the
controller's contact flags), give the same estimate every tick: the base pose and twist the
controller reads, the feet, the biases and the covariance.

The tolerance: both run the same equations in the same order, so they differ only by rounding
(numpy's and Eigen's products sum in other orders, numpy's LU and Eigen's pivot alike but round
apart), about 1e-16 relative per operation. The filter is stable: a rounding difference decays
rather than grows, so over the recorded ticks the estimates stay within 1e-9 m (position, feet),
1e-9 m/s (velocity), 1e-9 rad (orientation) and 1e-9 of the covariance's largest entry: six
orders below the 5 mm the filter trusts a foot's kinematics to, and nine below what the
controller would notice."""

import numpy as np
import pinocchio as pin
import pytest

from lab.realism.knobs import knobs_from, preset
from lab.world.estimator import BaseEstimator
from lab.world.session import Session, SessionConfig

_kernel = pytest.importorskip("lab._kernel")

TICKS = 1500  # 1.5 s: the trot's start, lift-offs and touchdowns of every foot
TOLERANCE = 1e-9  # module docstring


def _recorded_trot(robot: str) -> tuple[list, object]:
    """Per tick of `robot` trotting at 0.4 m/s under `typical` (the layer's noise on, the base
    read through it: `estimator = "true"`): (truth, measured, contacts), and the knobs with the
    EKF on."""
    knobs = knobs_from(preset("typical", robot), {"estimator": "true"})
    session = Session(SessionConfig(robot=robot, realism=knobs))
    assert session.handle("gait", {"name": "trot"})["ok"]
    assert session.handle("velocity", {"vx": 0.4, "vy": 0.0, "yaw_rate": 0.2})["ok"]
    ticks = []
    for _ in range(TICKS):
        contacts = np.array(session.controller.references.contact_active, dtype=bool)
        session.tick()
        truth = tuple(np.array(a) for a in session._true_state)
        measured = (session.model.q.copy(), session.model.v.copy())
        ticks.append((truth, measured, contacts))
    assert not session.fell
    return ticks, session.robot, knobs_from(knobs, {"estimator": "ekf"})


@pytest.mark.parametrize("robot", ["anymal", "solo12"])
def test_the_cpp_ekf_gives_the_python_ekfs_estimate_every_tick(robot: str) -> None:
    ticks, robot_model, knobs = _recorded_trot(robot)
    python = BaseEstimator(knobs, robot_model, 1e-3, native=False)
    native = BaseEstimator(knobs, robot_model, 1e-3, native=True)
    assert python.filter is not None and native.native is not None
    (q0, v0), _, _ = ticks[0]
    python.reset(q0, v0)
    native.reset(q0, v0)
    worst = dict.fromkeys(("q", "v", "position", "rotation", "feet", "bias", "P"), 0.0)
    touchdowns = 0
    for truth, measured, contacts in ticks:
        before = python.filter.contacts.copy()
        (qp, vp), (qn, vn) = (
            python.read(truth, measured, contacts),
            native.read(truth, measured, contacts),
        )
        touchdowns += int(np.sum(contacts & ~before))
        x, ekf = python.filter.x, native.native
        rotation = float(np.linalg.norm(pin.log3(x.rotation.T @ ekf.rotation)))
        scale = float(np.max(np.abs(python.filter.P)))
        errors = {
            "q": np.max(np.abs(qp - qn)),
            "v": np.max(np.abs(vp - vn)),
            "position": np.max(np.abs(np.r_[x.position - ekf.position, x.velocity - ekf.velocity])),
            "rotation": rotation,
            "feet": np.max(np.abs(x.feet - ekf.feet)),
            "bias": np.max(
                np.abs(np.r_[x.accel_bias - ekf.accel_bias, x.gyro_bias - ekf.gyro_bias])
            ),
            "P": np.max(np.abs(python.filter.P - ekf.covariance)) / scale,
        }
        for name, error in errors.items():
            worst[name] = max(worst[name], float(error))
    assert max(worst.values()) < TOLERANCE, worst
    # the recording exercised what it should: touchdowns (the settling rule), and an estimate
    # that is not the measured state itself
    assert touchdowns > 10
    assert np.max(np.abs(qn[:3] - ticks[-1][1][0][:3])) > 1e-5
