"""The plant's per-tick calls through lab._plant (C) against its Python path: the same state,
touch sensing, contact checks, divergence reports and input errors."""

import numpy as np
import pytest

from lab.description import load_description
from lab.robot import build_robot
from lab.world import plant as plant_module
from lab.world.plant import MujocoPlant, SimulationDiverged

pytestmark = pytest.mark.skipif(plant_module._plant is None, reason="lab._plant is not built")

# Both paths call the same mj_step on the same inputs: their states agree to rounding (the
# base velocity's rotation into the base frame is the one computation done twice).
STATE_TOL = 1e-12


def _pair(name: str, scene: str = "flat") -> tuple[MujocoPlant, MujocoPlant]:
    robot = build_robot(load_description(name))
    native, python = MujocoPlant(robot, scene), MujocoPlant(robot, scene, native=False)
    assert native.native and not python.native
    return native, python


def _pd(plant: MujocoPlant, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    robot = plant.robot
    kp, kd = 20.0 * robot.torque_limits, 0.5 * robot.torque_limits
    return kp * (robot.q_standing[7:] - q[7:]) - kd * v[6:]


@pytest.mark.parametrize("name", ["anymal", "talos"])
def test_native_steps_agree_with_python_ones(name: str) -> None:
    """Standing down from a drop under joint PD, then tipped over onto the base: the same
    (q, v), touching feet and non-foot contact on every tick."""
    native, python = _pair(name)
    rng = np.random.default_rng(5)
    q0 = native.robot.q_standing.copy()
    q0[2] += 0.05
    v0 = rng.normal(scale=0.3, size=native.nv)
    tipped = q0.copy()
    tipped[3:7] = [1.0, 0.0, 0.0, 0.0]  # upside down: the base lands first
    touched_any, non_foot_any = False, False
    for start in (q0, tipped):
        native.reset(start, v0)
        python.reset(start, v0)
        for _ in range(300):
            (q, v), (q_py, v_py) = native.state(), python.state()
            np.testing.assert_allclose(q, q_py, atol=STATE_TOL)
            np.testing.assert_allclose(v, v_py, atol=STATE_TOL * (1 + np.abs(v_py).max()))
            for threshold in (0.0, 1.0, 50.0):
                np.testing.assert_array_equal(
                    native.feet_touching(threshold), python.feet_touching(threshold)
                )
            assert native.non_foot_ground_contact() == python.non_foot_ground_contact()
            np.testing.assert_allclose(
                native.foot_forces(), python.foot_forces(), rtol=1e-12, atol=1e-9
            )
            touched_any |= bool(native.feet_touching(1.0).any())
            non_foot_any |= native.non_foot_ground_contact()
            tau = _pd(python, q_py, v_py)
            native.set_torques(tau)
            python.set_torques(tau)
            native.step()
            python.step()
            native.check()
            assert native.time == python.time
    assert touched_any and non_foot_any  # both kinds of contact were compared


def test_native_divergence_and_bad_torques_are_reported_as_in_python() -> None:
    native, python = _pair("solo12")
    for plant in (native, python):
        with pytest.raises(ValueError, match="torques"):
            plant.set_torques(np.ones(plant.nv - 5))
        with pytest.raises(ValueError, match="torques"):
            plant.set_torques(np.full(plant.nv - 6, np.nan))
        assert not plant.mj_data.ctrl.any()
    causes = []
    for plant in (native, python):
        plant.set_torques(np.zeros(plant.nv - 6))
        for _ in range(10):
            plant.step()
        plant.mj_data.qvel[-1] = 1e12  # rad/s: beyond MuJoCo's 1e10
        with pytest.raises(SimulationDiverged) as raised:
            plant.step()
        causes.append((raised.value.cause, raised.value.time))
        with pytest.raises(SimulationDiverged):
            plant.check()  # still bad until a reset
    assert causes[0] == causes[1]
    assert "velocity" in causes[0][0]


def test_native_steps_agree_on_moving_terrain() -> None:
    """A scene whose terrain moves (its script drives a joint before each step, and its geoms
    are terrain though not on the world body): the same state and touching feet."""
    native, python = _pair("anymal", "balance_board")
    assert native.moving_terrain.body_ids  # the board is a moving body
    for _ in range(300):
        (q, v), (q_py, v_py) = native.state(), python.state()
        np.testing.assert_allclose(q, q_py, atol=STATE_TOL)
        np.testing.assert_allclose(v, v_py, atol=STATE_TOL * (1 + np.abs(v_py).max()))
        np.testing.assert_array_equal(native.feet_touching(1.0), python.feet_touching(1.0))
        tau = _pd(python, q_py, v_py)
        native.set_torques(tau)
        python.set_torques(tau)
        native.step()
        python.step()
    assert native.feet_touching(1.0).all()  # it stands on the board: contacts were compared
