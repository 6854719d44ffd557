"""Controllers on real robot models and disturbed states (from
tests/controller/test_controller.py)."""

import numpy as np
import pinocchio as pin

from lab.controller.behaviours.balance import standing_references
from lab.controller.constraints import ContactLimits
from lab.controller.controller import ControllerConfig, WholeBodyController
from lab.controller.model import RobotModel
from lab.controller.stack import Stack
from lab.description import load_description
from lab.robot import build_robot


def controller_for(name: str, method: str = "cascade", solver: str = "daqp"):
    description = load_description(name)
    robot = build_robot(description)
    model = RobotModel(robot.model, robot.contacts)
    config = ControllerConfig(
        Stack.of(description.stack),
        dict(description.gains),
        method,
        solver,
        ContactLimits(friction=description.friction),
    )
    refs = standing_references(model, robot.q_standing)
    controller = WholeBodyController(model, refs, config, robot.torque_limits)
    controller.set_hands(  # as a session does
        tuple(frame for _, frame in description.hands), description.hand_joints
    )
    return controller, robot


def disturbed_state(robot, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The standing posture, a little off: joints by ±0.05 rad, base moving, base tilted."""
    q = robot.q_standing.copy()
    q[7:] += rng.uniform(-0.05, 0.05, len(q) - 7)
    rotation = pin.rpy.rpyToMatrix(*rng.uniform(-0.05, 0.05, 3))
    q[3:7] = pin.Quaternion(rotation).coeffs()
    v = rng.normal(0.0, 0.1, robot.model.nv)
    return q, v
