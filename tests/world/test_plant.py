"""The MuJoCo plant: conventions in and out, free fall, pushes, contact detection and forces."""

import math

import numpy as np
import pinocchio as pin
import pytest

from lab.description import ROBOT_NAMES, load_description
from lab.experiments.robot_check import posture_hold_gains
from lab.robot import build_robot
from lab.scenes.terrain import scripted_joint_name
from lab.world.plant import MujocoPlant, SimulationDiverged

G = 9.81
DT = 1e-3
# Semi-implicit Euler falls by g dt² n(n+1)/2 after n steps: g dt t / 2 ahead of g t² / 2.
FALL_TOL = 0.5 * G * DT * 0.1 + 1e-9  # m, after 0.1 s
# External forces change the momentum by their impulse (and its moment about the CoM); with the
# joints swinging freely, semi-implicit Euler adds a first-order error: measured at dt = 1 ms up to
# 2.8e-3 (angular, Talos pushed off-centre) and 3.3e-2 (G1, whose light wrists swing fast), ten
# times smaller at dt = 0.1 ms, where the test runs: ≤ 3.4e-3 on every robot.
MOMENTUM_REL_TOL = 5e-3  # of the expected change
PUSH_DT = 1e-4  # s, the push test's time step
STEP_MOTION_TOL = 1e-3  # m or rad: the platform moves < 1 m/s, < 1 rad/s, for one 1 ms step
FORCE_TOL = 0.02  # relative: feet carry the weight once a PD-held stance has settled


@pytest.fixture(scope="module", params=ROBOT_NAMES)
def plant(request) -> MujocoPlant:
    return MujocoPlant(build_robot(load_description(request.param)))


def _in_the_air(plant: MujocoPlant) -> np.ndarray:
    q = plant.robot.q_standing.copy()
    q[2] += 2.0
    return q


def test_state_round_trip(plant: MujocoPlant) -> None:
    model = plant.robot.model
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v = rng.normal(size=model.nv)
        plant.reset(q, v)
        q_out, v_out = plant.state()
        np.testing.assert_allclose(q_out, q, atol=1e-14)
        np.testing.assert_allclose(v_out, v, atol=1e-13)
    assert plant.time == 0.0


def test_free_fall_under_zero_torque(plant: MujocoPlant) -> None:
    q0 = _in_the_air(plant)
    plant.reset(q0)
    plant.set_torques(np.zeros(plant.nv - 6))
    for _ in range(100):
        plant.step()
    q, v = plant.state()
    t = plant.time
    assert t == pytest.approx(0.1)
    assert abs(q[2] - (q0[2] - 0.5 * G * t**2)) < FALL_TOL
    assert v[2] == pytest.approx(-G * t, abs=1e-9)  # base frame = world frame: no rotation
    np.testing.assert_allclose(v[3:], 0.0, atol=1e-9)
    assert not plant.non_foot_ground_contact()
    np.testing.assert_array_equal(plant.foot_forces(), 0.0)
    assert not plant.feet_touching(0.0).any()


def _momentum(plant: MujocoPlant) -> tuple[np.ndarray, np.ndarray]:
    """(linear, angular about the CoM) momentum of the whole robot, world frame."""
    model = plant.robot.model
    momentum = pin.computeCentroidalMomentum(model, model.createData(), *plant.state())
    return momentum.linear.copy(), momentum.angular.copy()


@pytest.mark.parametrize("at_point", [False, True])
def test_push_changes_momentum_by_impulse(plant: MujocoPlant, at_point: bool) -> None:
    """A push of F for T on the base in the air adds F T to the linear momentum, and the moment of
    F about the moving CoM to the angular momentum (F acts at the base CoM, or at a point fixed
    to the base)."""
    plant = MujocoPlant(plant.robot, timestep=PUSH_DT)
    model = plant.robot.model
    data = model.createData()
    base_link = next(f.name for f in model.frames if f.type == pin.FrameType.BODY)  # root link
    mass = pin.computeTotalMass(model)
    force = np.array([30.0, -20.0, 10.0]) * mass / 50.0
    plant.reset(_in_the_air(plant))
    linear0, angular0 = _momentum(plant)
    local = np.array([0.1, 0.05, 0.02]) if at_point else model.inertias[1].lever
    point = plant.state()[0][:3] + local  # base orientation is the identity at start
    plant.push(base_link, force, point if at_point else None)
    moment = np.zeros(3)
    for _ in range(round(0.1 / PUSH_DT)):
        q, _ = plant.state()
        com = pin.centerOfMass(model, data, q)
        moment += PUSH_DT * np.cross(data.oMi[1].act(local) - com, force)
        plant.step()
    plant.clear_push()
    linear, angular = _momentum(plant)
    impulse = (force + mass * np.array([0.0, 0.0, -G])) * plant.time
    scale = np.linalg.norm(force * plant.time)
    assert np.abs(linear - linear0 - impulse).max() < MOMENTUM_REL_TOL * scale
    assert np.abs(angular - angular0 - moment).max() < MOMENTUM_REL_TOL * np.linalg.norm(moment)


def test_bad_input_is_rejected_and_changes_nothing(plant: MujocoPlant) -> None:
    plant.reset(plant.robot.q_standing)
    with pytest.raises(KeyError) as error:
        plant.push("no_such_link", np.array([1.0, 0.0, 0.0]))
    assert all(name in str(error.value) for name in plant.body_names)
    with pytest.raises(ValueError, match="finite"):
        plant.push(plant.body_names[0], np.array([np.nan, 0.0, 0.0]))
    assert not plant.mj_data.xfrc_applied.any()
    with pytest.raises(ValueError, match="torques"):
        plant.set_torques(np.ones(plant.nv - 5))
    assert not plant.mj_data.ctrl.any()
    bad_q = plant.robot.q_standing.copy()
    bad_q[3:7] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(ValueError, match="quaternion"):
        plant.reset(bad_q)
    np.testing.assert_array_equal(plant.state()[0], plant.robot.q_standing)


def test_standing_touches_with_feet_only_and_feet_carry_the_weight(plant: MujocoPlant) -> None:
    robot = plant.robot
    plant.reset(robot.q_standing)
    kp, kd = posture_hold_gains(robot)  # a 60 rad/s PD on each joint's own inertia
    for _ in range(20):
        q, v = plant.state()
        plant.set_torques(kp * (robot.q_standing[7:] - q[7:]) - kd * v[6:])
        plant.step()
        assert not plant.non_foot_ground_contact()
    assert plant.foot_forces()[:, 2].min() > 0.0  # every foot is loaded
    assert plant.feet_touching(1.0).all()
    assert not plant.feet_touching(plant.foot_forces()[:, 2].max() + 1.0).any()


@pytest.mark.parametrize("name", ["anymal", "solo12", "talos"])
def test_foot_forces_sum_to_weight_in_a_settled_stance(name: str) -> None:
    robot = build_robot(load_description(name))
    plant = MujocoPlant(robot)
    kp, kd = 20.0 * robot.torque_limits, 0.5 * robot.torque_limits
    for _ in range(1000):
        q, v = plant.state()
        plant.set_torques(kp * (robot.q_standing[7:] - q[7:]) - kd * v[6:])
        plant.step()
    weight = pin.computeTotalMass(robot.model) * G
    total = plant.foot_forces().sum(axis=0)
    assert total[2] == pytest.approx(weight, rel=FORCE_TOL)
    assert np.hypot(total[0], total[1]) < FORCE_TOL * weight


def test_base_dropped_on_the_floor_is_a_non_foot_contact(plant: MujocoPlant) -> None:
    q = plant.robot.q_standing.copy()
    q[3:7] = [1.0, 0.0, 0.0, 0.0]  # upside down: legs up, base first
    q[2] += 0.3
    plant.reset(q)
    plant.set_torques(np.zeros(plant.nv - 6))
    touched = False
    for _ in range(1000):
        plant.step()
        if plant.non_foot_ground_contact():
            touched = True
            break
    assert touched


def test_unknown_scene_names_the_known_ones() -> None:
    robot = build_robot(load_description("solo12"))
    with pytest.raises(KeyError, match="flat"):
        MujocoPlant(robot, scene="moon")


def test_a_diverging_step_raises_instead_of_mujoco_resetting_the_state() -> None:
    """MuJoCo's automatic reset is off: a bad state raises SimulationDiverged naming the cause,
    the clock is not thrown back, and `reset` puts the robot at any sim time."""
    plant = MujocoPlant(build_robot(load_description("solo12")))
    plant.set_torques(np.zeros(plant.nv - 6))
    for _ in range(10):
        plant.step()
    plant.mj_data.qvel[-1] = 1e12  # rad/s: beyond MuJoCo's 1e10
    with pytest.raises(SimulationDiverged, match="velocity") as raised:
        plant.step()
    assert raised.value.time == pytest.approx(0.011)
    assert plant.time == pytest.approx(0.011)  # MuJoCo did not reset it to 0
    with pytest.raises(SimulationDiverged):
        plant.check()  # still bad until a reset
    plant.reset(plant.robot.q_standing, time=raised.value.time)
    plant.step()
    assert plant.time == pytest.approx(0.012)
    with pytest.raises(ValueError, match="time"):
        plant.reset(plant.robot.q_standing, time=math.nan)


def test_joint_damping_is_settable_and_checked() -> None:
    plant = MujocoPlant(build_robot(load_description("solo12")))
    plant.set_joint_damping(0.3)
    assert np.all(plant.mj_model.dof_damping[6:] == 0.3)
    assert np.all(plant.mj_model.dof_damping[:6] == 0.0)  # the base is never damped
    with pytest.raises(ValueError, match="damping"):
        plant.set_joint_damping(-1.0)
    plant.set_joint_damping(0.0)
    assert not plant.mj_model.dof_damping.any()


def test_the_terrain_reads_name_the_moving_platform_and_agree_with_each_other() -> None:
    """`scripted_joint_positions`, `terrain_frame` and `scene_body_poses` (what metrics and
    telemetry read instead of MuJoCo's data): empty and the world's frame in a static scene; on
    the rolling platform, its six joints by name, moving, and the frame they make (slides along
    the world's x, y, z, then hinges about z, y, x) is the frame and pose read."""
    robot = build_robot(load_description("solo12"))
    still = MujocoPlant(robot)
    position, rotation = still.terrain_frame()
    assert still.scripted_joint_positions() == {}
    assert still.scene_body_poses() == {}
    assert np.allclose(position, 0.0) and np.allclose(rotation, np.eye(3))

    plant = MujocoPlant(robot, scene="platform")
    for _ in range(600):  # 0.6 s: past half the platform's fade-in
        plant.step()
    joints = plant.scripted_joint_positions()
    assert list(joints) == [scripted_joint_name("platform", k) for k in range(6)]
    x, y, z, yaw, pitch, roll = joints.values()
    assert abs(y) > 1e-3 and abs(yaw) > 1e-3  # it moves
    position, rotation = plant.terrain_frame()
    # The frame is the last step's kinematics, the joints after its integration: a step apart.
    assert np.allclose(position, [x, y, z], atol=STEP_MOTION_TOL)
    expected = pin.rpy.rpyToMatrix(roll, pitch, yaw)  # Rz(yaw) Ry(pitch) Rx(roll)
    assert np.allclose(rotation, expected, atol=STEP_MOTION_TOL)
    assert np.allclose(plant.scene_body_poses()["platform"][:3], position, atol=1e-12)
