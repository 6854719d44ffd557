"""`lab robot check NAME`: does a robot description work in both engines and stand?

Three checks, each a `Finding` in plain words:
- **engines** — pinocchio and MuJoCo, loaded from the same URDF, agree on the mass matrix, the
  bias forces, the CoM and the contact frames' placements and Jacobians on random states
  (`engine_agreement`; `tests/robot/test_consistency.py` holds every shipped robot to it).
- **rest** — at the standing posture only the feet touch the ground, and every foot does.
- **stand** — the default controller keeps the robot standing for a few seconds: no fall, no
  QP failure, the base within a centimetre and a few hundredths of a radian of where it started.

MuJoCo's velocity is qvel = T v with T = diag(R, I, P) (world-frame linear velocity, joints
permuted by name), so M_pin = Tᵀ M_mj T and, since MuJoCo's free-joint acceleration is
d/dt(R v_lin) = R v̇_lin + R (ω × v_lin), h_pin = Tᵀ (h_mj + M_mj Ṫv) with
Ṫv = [R (ω × v_lin), 0, 0].
"""

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from lab.description import load_description
from lab.robot import Robot, build_robot
from lab.world.plant import MujocoPlant

# Both engines compute in double precision from the same URDF numbers, so only round-off is left:
# measured ≤ 1.2e-15 on every shipped robot. Errors are the largest absolute difference over the
# largest entry of the pinocchio quantity (at least 1); 1e-12 leaves three decades of margin.
AGREEMENT_TOL = 1e-12
STAND_SECONDS = 5.0
REST_STEPS = 20  # 20 ms of the plant from the standing posture, held by a PD
REST_BANDWIDTH = 60.0  # rad/s
STAND_HEIGHT_TOL = 0.01  # m, the base's largest height error while standing
STAND_ORIENTATION_TOL = 0.05  # rad, the base's largest orientation error while standing


@dataclass(frozen=True)
class Finding:
    """One check's outcome: `ok`, and a sentence saying what was found."""

    check: str
    ok: bool
    message: str


def random_state(rng: np.random.Generator, model: pin.Model) -> tuple[np.ndarray, np.ndarray]:
    """A random (q, v) within the joint limits (and ±π), the base anywhere in a 2 m box."""
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


def engine_agreement(robot: Robot, states: int = 20, seed: int = 7) -> dict[str, float]:
    """The largest relative disagreement of the two engines over `states` random states, per
    quantity: total mass, CoM, M, h, the contact frames' position, rotation and Jacobian."""
    plant = MujocoPlant(robot)
    model, data = robot.model, robot.model.createData()
    m, d = plant.mj_model, plant.mj_data
    frame_ids = [model.getFrameId(c.frame) for c in robot.contacts]
    rng = np.random.default_rng(seed)
    mass_mj = np.zeros((m.nv, m.nv))
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    worst = dict.fromkeys(["com", "M", "h", "position", "rotation", "jacobian"], 0.0)
    worst["mass"] = _rel_err(np.sum(m.body_mass), pin.computeTotalMass(model))
    for _ in range(states):
        q, v = random_state(rng, model)
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
    return worst


def _check_engines(robot: Robot) -> Finding:
    worst = engine_agreement(robot)
    bad = {name: error for name, error in worst.items() if not error < AGREEMENT_TOL}
    if bad:
        listed = ", ".join(f"{name} off by {error:.1e}" for name, error in bad.items())
        return Finding(
            "engines",
            False,
            f"pinocchio and MuJoCo disagree ({listed}, allowed {AGREEMENT_TOL:.0e}): an inertia "
            "MuJoCo rebalanced, a joint the two read differently, or a contact frame on the "
            "wrong link",
        )
    return Finding(
        "engines",
        True,
        f"pinocchio and MuJoCo agree to {max(worst.values()):.1e} (mass matrix, bias forces, "
        "CoM, contact frames and Jacobians)",
    )


def posture_hold_gains(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """(kp, kd) of a REST_BANDWIDTH PD on each joint's own inertia (the mass matrix's diagonal
    at the standing posture): stiff at every robot's scale and stable at 1 kHz (gains scaled by
    the torque limit chattered on the A1's light legs, lifting every foot)."""
    inertia = np.diag(pin.crba(robot.model, robot.model.createData(), robot.q_standing))[6:]
    return REST_BANDWIDTH**2 * inertia, 2.0 * REST_BANDWIDTH * inertia


def _check_rest(robot: Robot) -> Finding:
    plant = MujocoPlant(robot)
    plant.reset(robot.q_standing)
    # Held while the contacts form: the feet stand exactly on the floor at the posture.
    kp, kd = posture_hold_gains(robot)
    for _ in range(REST_STEPS):
        q, v = plant.state()
        plant.set_torques(kp * (robot.q_standing[7:] - q[7:]) - kd * v[6:])
        plant.step()
    if plant.non_foot_ground_contact():
        return Finding(
            "rest",
            False,
            "at the standing posture something other than a foot touches the ground: a "
            "collision mesh reaches below the feet (shorten it, or check the contact frames)",
        )
    touching = plant.feet_touching(0.0)
    if not touching.all():
        missing = [c.name for c, t in zip(robot.contacts, touching, strict=True) if not t]
        return Finding(
            "rest",
            False,
            f"at the standing posture the feet {missing} do not touch the ground: the posture "
            "or the contact frames put them in the air",
        )
    return Finding("rest", True, "at the standing posture every foot and nothing else touches")


def _check_stand(name: str, seconds: float) -> Finding:
    from lab.experiments.scenario import Scenario, run_scenario
    from lab.world.session import SessionConfig

    report = run_scenario(Scenario(f"{name}_check", seconds, SessionConfig(robot=name)))
    metrics = report["metrics"]
    height, tilt = metrics["max_base_height_error_m"], metrics["max_base_orientation_error_rad"]
    if report["fell"] or report["qp_failures"] or report["divergences"]:
        return Finding(
            "stand",
            False,
            f"the default controller did not keep it standing for {seconds:g} s (fell "
            f"{report['fell']}, {report['qp_failures']} QP failures, {report['divergences']} "
            "divergences): check the posture, the torque limits and the default stack",
        )
    if height > STAND_HEIGHT_TOL or tilt > STAND_ORIENTATION_TOL:
        return Finding(
            "stand",
            False,
            f"it stands but sags: the base strays {height * 100:.1f} cm and {tilt:.3f} rad "
            f"(allowed {STAND_HEIGHT_TOL * 100:.0f} cm, {STAND_ORIENTATION_TOL} rad): the "
            "torque limits may be too low for its weight",
        )
    return Finding(
        "stand",
        True,
        f"stands {seconds:g} s under its default stack: the base within {height * 1000:.1f} mm "
        f"and {tilt:.4f} rad, {report['realtime_factor']:.1f}x real time",
    )


def check_robot(name: str, stand_seconds: float = STAND_SECONDS) -> list[Finding]:
    """Every check of robot `name`, in order; a description that does not load is one finding
    (the later checks need it)."""
    try:
        robot = build_robot(load_description(name))
    except (KeyError, ValueError, OSError) as error:
        return [Finding("load", False, f"robots/{name}.toml does not load: {error}")]
    findings = [Finding("load", True, f"loads: {robot.model.nv} DoF, {len(robot.contacts)} feet")]
    findings.append(_check_engines(robot))
    findings.append(_check_rest(robot))
    if findings[-1].ok:
        findings.append(_check_stand(name, stand_seconds))
    return findings
