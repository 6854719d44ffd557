"""Pinocchio and MuJoCo agree on the rigid-body model of every robot, on random states.

Both engines load the same URDF (lab.description / lab.server.plant). MuJoCo's velocity is
qvel = T v with T = diag(R, I, P) (world-frame linear velocity, joints permuted by name), so
M_pin = Tᵀ M_mj T and, since MuJoCo's free-joint acceleration is d/dt(R v_lin) = R v̇_lin +
R (ω × v_lin), h_pin = Tᵀ (h_mj + M_mj Ṫv) with Ṫv = [R (ω × v_lin), 0, 0].
"""

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from lab.description import ROBOT_NAMES, load_description
from lab.robot import build_robot
from lab.server.plant import MujocoPlant

N_STATES = 20
# Both engines compute in double precision from the same URDF numbers, so only round-off is left:
# measured ≤ 1.2e-15 for every robot and quantity. Errors are the largest absolute difference over
# the largest entry of the pinocchio quantity (at least 1); 1e-12 leaves three decades of margin.
REL_TOL = 1e-12


def _random_state(rng: np.random.Generator, model: pin.Model) -> tuple[np.ndarray, np.ndarray]:
    lower = np.maximum(model.lowerPositionLimit[7:], -np.pi)
    upper = np.minimum(model.upperPositionLimit[7:], np.pi)
    quaternion = rng.normal(size=4)
    position = rng.uniform([-1.0, -1.0, 0.0], [1.0, 1.0, 2.0])
    q = np.concatenate(
        [position, quaternion / np.linalg.norm(quaternion), rng.uniform(lower, upper)]
    )
    v = np.concatenate([rng.normal(0.0, 1.0, 6), rng.normal(0.0, 3.0, model.nv - 6)])
    return q, v


def _rel_err(mujoco_value: np.ndarray, pinocchio_value: np.ndarray) -> float:
    scale = max(1.0, float(np.abs(pinocchio_value).max()))
    return float(np.abs(mujoco_value - pinocchio_value).max()) / scale


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_engines_agree_on_random_states(name: str) -> None:
    robot = build_robot(load_description(name))
    plant = MujocoPlant(robot)
    model, data = robot.model, robot.model.createData()
    m, d = plant.mj_model, plant.mj_data
    frame_ids = [model.getFrameId(c.frame) for c in robot.contacts]
    rng = np.random.default_rng(7)
    mass_mj = np.zeros((m.nv, m.nv))
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    worst = dict.fromkeys(["com", "M", "h", "position", "rotation", "jacobian"], 0.0)

    assert _rel_err(np.sum(m.body_mass), pin.computeTotalMass(model)) < REL_TOL
    for _ in range(N_STATES):
        q, v = _random_state(rng, model)
        plant.reset(q, v)
        t = plant.velocity_map(q)
        mujoco.mj_fullM(m, d, mass_mj)

        mass_pin = pin.crba(model, data, q)
        mass_pin = np.triu(mass_pin) + np.triu(mass_pin, 1).T
        worst["M"] = max(worst["M"], _rel_err(t.T @ mass_mj @ t, mass_pin))

        t_dot_v = np.zeros(m.nv)
        t_dot_v[:3] = t[:3, :3] @ np.cross(v[3:6], v[:3])
        h_mj = t.T @ (d.qfrc_bias + mass_mj @ t_dot_v)
        worst["h"] = max(worst["h"], _rel_err(h_mj, pin.nle(model, data, q, v)))

        com = pin.centerOfMass(model, data, q)
        worst["com"] = max(worst["com"], _rel_err(d.subtree_com[plant.base_body_id], com))

        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for site, fid in zip(plant.contact_site_ids, frame_ids, strict=True):
            placement = data.oMf[fid]
            worst["position"] = max(
                worst["position"], _rel_err(d.site_xpos[site], placement.translation)
            )
            worst["rotation"] = max(
                worst["rotation"], _rel_err(d.site_xmat[site].reshape(3, 3), placement.rotation)
            )
            mujoco.mj_jacSite(m, d, jacp, jacr, site)
            jac_pin = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            worst["jacobian"] = max(
                worst["jacobian"], _rel_err(np.vstack([jacp, jacr]) @ t, jac_pin)
            )
    print(name, {k: f"{e:.1e}" for k, e in worst.items()})
    assert max(worst.values()) < REL_TOL, worst
