"""Figs. 4–5 of Kim 2016 for Bolt: the planner's predicted against the actual CoM phase
portraits, forward (x, ẋ) and lateral (y, ẏ), around the first push of `bolt_push_recovery`.

Runs the scenario headless up to END_S, keeps each step's last plan (`biped_step`'s
`prediction`: over the stance foot to the switch, then over the new foot for t′) and the CoM's
path in the heading frame, and plots both for the steps between START_S and END_S into
docs/kim_phase_portraits.png: `python docs/figures/kim_phase_portraits.py`.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from lab.experiments.scenario import load_scenario
from lab.world.session import Session

ROOT = Path(__file__).resolve().parent.parent.parent
SCENARIO = ROOT / "scenarios" / "bolt_push_recovery.toml"
START_S, END_S = 2.5, 4.0  # the first push, 1.5 N sideways, comes at 3.0 s
OUT = Path(__file__).resolve().parent.parent / "kim_phase_portraits.png"


def run() -> tuple[np.ndarray, list]:
    """The CoM path (rows t, x, y, ẋ, ẏ; heading frame) and each step's last prediction."""
    scenario = load_scenario(SCENARIO)
    session = Session(scenario.config)
    pending = list(scenario.events)
    path, plans = [], []
    while session.time < END_S - 1e-9:
        while pending and pending[0].t <= session.time + 1e-9:
            event = pending.pop(0)
            assert session.handle(event.verb, event.payload)["ok"], event
        steps = getattr(session.behaviour, "steps", 0)
        session.tick()
        assert not session.fell, f"fell at {session.time:.2f} s"
        stepping = session.behaviour
        if stepping.steps > steps and stepping.prediction is not None:
            plans.append(stepping.prediction)  # the plan the foot just landed on
        tel = session.telemetry()["stepping"]
        if session.time >= START_S and tel is not None:
            path.append([session.time, *tel["com"], *tel["com_velocity"]])
    return np.array(path), [p for p in plans if p.t >= START_S]


def main() -> None:
    """Simulate and save the figure."""
    path, plans = run()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, (axis, label) in zip(axes, ((0, "forward x"), (1, "lateral y")), strict=True):
        ax.plot(path[:, 1 + axis], path[:, 3 + axis], color="tab:red", lw=1.2, label="actual")
        for i, plan in enumerate(plans):
            rows = plan.forward if axis == 0 else plan.lateral
            ax.plot(rows[:, 1], rows[:, 2], "--", color="tab:blue", lw=1.0,
                    label="predicted (last plan of each step)" if i == 0 else None)  # fmt: skip
            ax.plot(rows[0, 1], rows[0, 2], "o", color="tab:blue", ms=3)
            ax.plot(plan.foot[axis], 0.0, "^", color="k", ms=6,
                    label="footstep" if i == 0 else None)  # fmt: skip
        ax.axhline(0.0, color="0.7", lw=0.8)
        ax.set_xlabel(f"CoM {label} [m]")
        ax.set_ylabel(f"CoM velocity {label.split()[1]} [m/s]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle(
        f"Bolt, biped_step at 0.1 m/s, {START_S}–{END_S} s: 1.5 N sideways for 0.1 s at 3.0 s "
        "(predicted: to the switch, then t′ over the planned foot)"
    )
    fig.tight_layout()
    fig.savefig(OUT, dpi=90)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
