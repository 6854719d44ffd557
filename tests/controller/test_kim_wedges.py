"""Kim 2016 §VI-A on Bolt: the split_wedges scene and the internal force that keeps Bolt on it."""

from pathlib import Path

import numpy as np
import pinocchio as pin

from lab.controller.behaviours.balance import standing_references
from lab.controller.model import RobotModel
from lab.controller.tasks import TASK_TYPES, TaskGains
from lab.description import load_description
from lab.experiments.scenario import load_scenario, run_scenario
from lab.robot import build_robot
from lab.scenes import scene_geoms
from lab.scenes.split_wedges import wedge_normal

SCENARIOS = Path(__file__).parent.parent.parent / "scenarios"


def test_bolts_standing_feet_touch_both_wedge_faces() -> None:
    robot = build_robot(load_description("bolt"))
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_standing)
    geoms = {g.name: g for g in scene_geoms("split_wedges")}
    sides = ((1, "left_wedge"), (-1, "right_wedge"))
    for contact, (side, name) in zip(robot.contacts, sides, strict=True):
        centre = data.oMf[robot.model.getFrameId(contact.frame)].translation
        wedge = geoms[name]
        normal = wedge_normal(side)
        face = np.array(wedge.position) + wedge.size[2] * normal  # top face centre
        assert abs(normal @ (centre - face) - contact.radius) < 1e-3  # tangent, within 1 mm


def test_the_scaled_100_n_internal_force_holds_bolt_and_10_n_does_not() -> None:
    """Fig. 6/7 scaled by weight: 0.51 m g balances (measured internal force within 0.2 N of
    the 6.27 N reference, feet sliding less than 5 mm in 1.5 s); 0.05 m g slips and falls."""
    holds = run_scenario(load_scenario(SCENARIOS / "kim_wedges_100n.toml"), duration=1.5)
    assert not holds["fell"]
    assert abs(holds["metrics"]["internal_force_mean_error_n"]) < 0.2
    assert holds["metrics"]["max_foot_slide_m"] < 0.005
    slips = run_scenario(load_scenario(SCENARIOS / "kim_wedges_10n.toml"), duration=1.5)
    assert slips["fell"]


def test_the_com_along_and_across_the_foot_line_are_the_com_rows_in_those_directions() -> None:
    """Fig. 6c's CoM impedance split on Bolt: `com_along_feet` and `com_across_feet` are one row
    each, the 3-D CoM rows projected on the horizontal foot line and across it; with a foot
    lifted they have no rows."""
    robot = build_robot(load_description("bolt"))
    model = RobotModel(robot.model, robot.contacts)
    refs = standing_references(model, robot.q_standing)
    rng = np.random.default_rng(3)
    q = robot.q_standing.copy()
    q[7:] += rng.uniform(-0.1, 0.1, len(q) - 7)
    model.update(q, rng.uniform(-0.5, 0.5, model.nv))
    refs.com = refs.com + np.array([0.01, -0.02, 0.005])
    gains = TaskGains(kp=50.0, kd=14.0)
    A, b, e = TASK_TYPES["com"](gains).rows(model, refs)
    line = model.contact_positions[1] - model.contact_positions[0]
    line[2] = 0.0
    line /= np.linalg.norm(line)
    across = np.cross(line, [0.0, 0.0, 1.0])
    for name, direction in (("com_along_feet", line), ("com_across_feet", across)):
        rows = TASK_TYPES[name](gains).rows(model, refs)
        assert rows.A.shape == (1, model.nx)
        np.testing.assert_allclose(rows.A[0], direction @ A, atol=1e-12)
        np.testing.assert_allclose(rows.b, [direction @ b], atol=1e-12)
        np.testing.assert_allclose(rows.error, [direction @ e], atol=1e-12)
        refs.contact_active[1] = False
        assert TASK_TYPES[name](gains).rows(model, refs).A.shape == (0, model.nx)
        refs.contact_active[1] = True


def test_a_downward_push_is_taken_with_the_com_soft_only_along_the_foot_line() -> None:
    """Fig. 6c: 10 N (0.8 m g) down for 0.2 s at 1 s. With the CoM soft along the foot line and
    stiff across it Bolt stands (soft both ways, `com_xy` at kp 50, it fell at 2.05 s); the CoM
    sinks about as a 400 /s² spring does (0.8 g / 400 = 19.6 mm) and the internal force holds."""
    run = run_scenario(load_scenario(SCENARIOS / "kim_wedges_impedance_down.toml"), duration=2.3)
    assert not run["fell"]
    assert 0.015 < run["metrics"]["cog_error_z_max_m"] < 0.03
    assert run["metrics"]["internal_force_max_error_n"] < 0.5
