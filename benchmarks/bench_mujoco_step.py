"""MuJoCo's step for one robot, stage by stage, and what its model options would change.

    .venv/bin/python benchmarks/bench_mujoco_step.py [--robot g1] [--ticks 1000]

A session of the robot stands under its default controller (native kernel when built) for
`--ticks` ticks after 0.5 s of settling, pushed sideways by a tenth of its weight for 0.1 s in
the middle; MuJoCo's integration state after each tick is recorded. Then, for the plant's model
as the lab builds it and for copies with one option changed, each recorded state is restored
and stepped once: median thread-CPU µs of `mj_step`, of the forward pass's stages
(`mj_fwdPosition`: kinematics, mass matrix, collision, constraint set-up; `mj_fwdVelocity`,
`mj_fwdActuation`, `mj_fwdAcceleration`, `mj_fwdConstraint`: the contact solver), the contact
count and the solver's iterations. The same states for every variant, so the variants compare
within one run; which variant keeps the physics the lab wants is docs/performance.md's call.
"""

import argparse
import copy
import os
import time
from collections.abc import Callable

import mujoco
import numpy as np

from lab.description import ROBOT_NAMES
from lab.world.session import Session, SessionConfig

SETTLE_TICKS = 500
STATE = mujoco.mjtState.mjSTATE_INTEGRATION
FORWARD = (
    ("position", mujoco.mj_fwdPosition),
    ("velocity", mujoco.mj_fwdVelocity),
    ("actuation", mujoco.mj_fwdActuation),
    ("acceleration", mujoco.mj_fwdAcceleration),
    ("constraint", mujoco.mj_fwdConstraint),
)
POSITION = (  # mj_fwdPosition's main stages, in its order
    ("kinematics", mujoco.mj_kinematics),
    ("com", mujoco.mj_comPos),
    ("mass matrix", mujoco.mj_crb),
    ("factor", mujoco.mj_factorM),
    ("collision", mujoco.mj_collision),
    ("constraints", mujoco.mj_makeConstraint),
)


def _option(name: str, value: int | float) -> Callable[[mujoco.MjModel], None]:
    return lambda m: setattr(m.opt, name, value)


def _feet_only(session: Session) -> Callable[[mujoco.MjModel], None]:
    """Only the feet collide (what the fall check's non-foot contact test could no longer see)."""

    def change(m: mujoco.MjModel) -> None:
        plant = session.plant
        root = m.body_rootid[plant.base_body_id]
        for g in range(m.ngeom):
            if m.body_rootid[m.geom_bodyid[g]] == root and g not in plant.foot_geom_ids:
                m.geom_contype[g] = m.geom_conaffinity[g] = 0

    return change


def record(robot: str, ticks: int) -> tuple[Session, list[np.ndarray]]:
    """A standing session and its MuJoCo integration state after each of `ticks` ticks."""
    session = Session(SessionConfig(robot=robot))
    m, d = session.plant.mj_model, session.plant.mj_data
    for _ in range(SETTLE_TICKS):
        session.tick()
    states = []
    force = 0.1 * session.model.mass * 9.81
    for i in range(ticks):
        if i == ticks // 2:
            push = {"body": session.robot.base_link, "force": [0.0, force, 0.0]}
            session.handle("push", {**push, "duration": 0.1})
        session.tick()
        state = np.empty(mujoco.mj_stateSize(m, STATE))
        mujoco.mj_getState(m, d, state, STATE)
        states.append(state)
    if session.fell:
        raise SystemExit(f"{robot} fell while recording: the states are not standing ones")
    return session, states


def time_stages(m: mujoco.MjModel, states: list[np.ndarray]) -> dict[str, float]:
    """Median thread-CPU µs of mj_step and of each forward stage from each state; the median
    contact count and solver iterations."""
    d = mujoco.MjData(m)
    clock = time.thread_time_ns
    spent: dict[str, list[float]] = {
        name: [] for name in ("step", *(n for n, _ in FORWARD), *(n for n, _ in POSITION))
    }
    contacts, iterations = [], []
    for state in states:
        for stages in (FORWARD, POSITION):
            mujoco.mj_setState(m, d, state, STATE)
            for name, stage in stages:
                start = clock()
                stage(m, d)
                spent[name].append(clock() - start)
        contacts.append(d.ncon)
        iterations.append(d.solver_niter[0])
        mujoco.mj_setState(m, d, state, STATE)
        start = clock()
        mujoco.mj_step(m, d)
        spent["step"].append(clock() - start)
    out = {name: float(np.median(ns)) / 1e3 for name, ns in spent.items()}
    out["contacts"] = float(np.median(contacts))
    out["iterations"] = float(np.median(iterations))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="g1", choices=ROBOT_NAMES)
    parser.add_argument("--ticks", type=int, default=1000)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    session, states = record(args.robot, args.ticks)
    model = session.plant.mj_model
    variants: dict[str, Callable[[mujoco.MjModel], None]] = {
        "as built": lambda m: None,
        "Euler integrator": _option("integrator", mujoco.mjtIntegrator.mjINT_EULER),
        "pyramidal cones": _option("cone", mujoco.mjtCone.mjCONE_PYRAMIDAL),
        "CG solver": _option("solver", mujoco.mjtSolver.mjSOL_CG),
        "sparse Jacobians": _option("jacobian", mujoco.mjtJacobian.mjJAC_SPARSE),
        "tolerance 1e-6": _option("tolerance", 1e-6),
        "feet only collide": _feet_only(session),
        "as built, again": lambda m: None,
    }
    print(
        f"{args.robot} standing (nv {model.nv}, {model.ngeom} geoms), MuJoCo from "
        f"{len(states)} recorded states, median µs of thread CPU time; load {load:.1f} before, "
        f"{os.getloadavg()[0]:.1f} after recording"
    )
    columns = ("step", *(n for n, _ in FORWARD), *(n for n, _ in POSITION))
    print(f"{'variant':18} " + " ".join(f"{c[:11]:>11}" for c in columns) + "  contacts  iter")
    for name, change in variants.items():
        m = copy.deepcopy(model)
        change(m)
        row = time_stages(m, states)
        print(
            f"{name:18} "
            + " ".join(f"{row[c]:11.1f}" for c in columns)
            + f"  {row['contacts']:8.0f}  {row['iterations']:4.0f}"
        )
    print(f"load {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
