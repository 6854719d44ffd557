"""Figs. 8 and 9 of Herzog 2016 for Talos: balancing on the rolling platform and on the balance
board, sagittal and lateral, the board dropped from its highest tilt at 2 s.

Runs the three scenarios headless (`herzog_platform`, `herzog_balance_board`,
`herzog_balance_board_lateral`: Table 2, LQR with Talos's cost) and plots, one column each, the
moving body's angular velocity and linear acceleration (what the paper's IMU on the plate
measured; the acceleration is the body's, gravity left out), the CoG error and each sole's CoP
(planned: the controller's contact wrench; measured: MuJoCo's contact points weighted by their
normal forces) along the sole and across it, as a fraction of its half size (±1: the edge;
the dotted lines are `cop_inner`'s bound); the motion on a symmetric log scale, the boards' runs
up to BOARD_END. Into docs/herzog_moving_scenes.png, beside Fig. 7's
push plots: `python docs/figures/herzog_moving_scenes.py` (needs matplotlib).
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mujoco
import numpy as np
from herzog_push_response import plot_column, save

from lab.controller.constraints import INNER_COP_MARGIN
from lab.experiments.scenario import load_scenario
from lab.world.session import Session

ROOT = Path(__file__).resolve().parent.parent.parent
SCENARIOS = {
    "herzog_platform": "Fig. 8: rolling platform",
    "herzog_balance_board": "Fig. 9: balance board, sagittal",
    "herzog_balance_board_lateral": "Fig. 9: balance board, lateral",
}
OUT = Path(__file__).resolve().parent.parent / "herzog_moving_scenes.png"
LOADED = 50.0  # N: a sole pressing less has no CoP plotted
SETTLE = 0.005  # s left out at the start: a sole's first contact points are its corners
BOARD_END = 4.0  # s shown of the boards' runs (still after 3 s)


def run(name: str) -> dict[str, np.ndarray]:
    """Time series of scenario `name`: t (s), the moving body's angular velocity (rad/s) and
    linear acceleration (m/s², world axes), the CoG error (m) and each sole's CoP, planned and
    measured, over its half size (n × 2 soles × 2 axes; NaN when the sole is not loaded)."""
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.toml")
    session = Session(scenario.config)
    plant, model = session.plant, session.model
    body = plant.moving_terrain.body_ids[0]
    m, d = plant.mj_model, plant.mj_data
    motion, gravity = np.zeros(6), np.array([0.0, 0.0, 9.81])
    pending = list(scenario.events)
    rows = []
    while session.time < scenario.duration - 1e-9:
        while pending and pending[0].t <= session.time + 1e-9:
            event = pending.pop(0)
            assert session.handle(event.verb, event.payload)["ok"], event
        session.tick()
        assert not session.fell, f"{name}: fell at {session.time:.2f} s"
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, body, motion, 0)
        angular = motion[:3].copy()
        mujoco.mj_rnePostConstraint(m, d)  # the bodies' accelerations, for the next call
        mujoco.mj_objectAcceleration(m, d, mujoco.mjtObj.mjOBJ_BODY, body, motion, 0)
        linear = motion[3:] - gravity  # MuJoCo's reads as an accelerometer: +g at rest
        error = model.com - session.controller.references.com
        measured = plant.foot_pressure_centres()
        pressing = np.linalg.norm(plant.foot_forces(), axis=1) > LOADED
        cops = np.full((2, 2, 2), np.nan)  # planned / measured, sole, axis
        for i, contact in enumerate(model.contacts):
            half = np.array([contact.half_length, contact.half_width])
            _, _, fz, tx, ty, _ = session.forces[model.force_slices[i]]
            if fz > LOADED:
                cops[0, i] = np.array([-ty, tx]) / fz / half
            if pressing[i]:
                local = model.contact_rotations[i].T @ (measured[i] - model.contact_positions[i])
                cops[1, i] = local[:2] / half
        if session.time < SETTLE:
            continue
        rows.append(np.concatenate(([session.time], angular, linear, error, cops.ravel())))
    data = np.array(rows)
    return {
        "t": data[:, 0],
        "angular": data[:, 1:4],
        "linear": data[:, 4:7],
        "cog": data[:, 7:10],
        "cop": data[:, 10:].reshape(-1, 2, 2, 2),
    }


def plot_cops(axes, series: dict[str, np.ndarray]) -> None:
    """The soles' CoPs along (first axes) and across (second) the sole, planned dashed."""
    styles = (("--", "planned"), ("-", "measured"))
    labels = ("CoP along sole", "CoP across sole")
    for axis, (ax, label) in enumerate(zip(axes, labels, strict=True)):
        for kind, (style, what) in enumerate(styles):
            for sole, colour in enumerate(("tab:blue", "tab:red")):
                side = ("left", "right")[sole]
                ax.plot(series["t"], series["cop"][:, kind, sole, axis], style, color=colour,
                        linewidth=0.9, label=f"{side} {what}")  # fmt: skip
        for bound in (1.0 - INNER_COP_MARGIN, -(1.0 - INNER_COP_MARGIN)):
            ax.axhline(bound, color="0.5", linestyle=":", linewidth=0.8)
        ax.set_ylim(-1.05, 1.05)
        ax.set_ylabel(f"{label} [half size]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")


def main() -> None:
    """Simulate the three scenes and save the figure."""
    fig, axes = plt.subplots(5, len(SCENARIOS), figsize=(15, 12))
    panels = (
        ("angular", 1.0, "scene angular velocity [rad/s]"),
        ("linear", 1.0, "scene linear acceleration [m/s²]"),
        ("cog", 100.0, "CoG error [cm]"),
    )
    for column, (name, title) in enumerate(SCENARIOS.items()):
        series = run(name)
        plot_column(axes[:3, column], series, panels, title)
        axes[2, column].set_xlabel("")
        plot_cops(axes[3:, column], series)
        for ax in axes[:2, column]:  # the boards' impact is 100 times the motion before it
            ax.set_yscale("symlog", linthresh=0.1 if ax is axes[0, column] else 1.0)
        if name != "herzog_platform":
            for ax in axes[:, column]:
                ax.set_xlim(0.0, BOARD_END)
    axes[0, 0].legend(loc="upper right")
    axes[3, 0].legend(loc="lower right", fontsize=7, ncol=2)
    save(fig, "Talos on moving ground, Table 2 stack, LQR with Talos's cost", OUT, 80)


if __name__ == "__main__":
    main()
