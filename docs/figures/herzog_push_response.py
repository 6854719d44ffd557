"""Fig. 7 of Herzog 2016 for Talos: one push, PD against LQR momentum control, under Table 2.

Runs three short headless sessions (the campaign's strongest hip push from the front, 293 N for
32 ms, 9.5 N s, at the pelvis) and plots the push force, the CoG error and the linear and angular
momentum against time, one column per law (PD, LQR with the paper's cost, LQR with the cost
retuned for Talos), into docs/herzog_push_response.png.
Needs matplotlib (not a dependency of the lab): `pip install matplotlib`, then
`python docs/figures/herzog_push_response.py`.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from lab.world.session import Session, SessionConfig

PUSH_FORCE = np.array([-293.0, 0.0, 0.0])  # N, at the pelvis, from the front
PUSH_DURATION = 0.0324  # s: 9.5 N s
SETTLE_S, PUSH_AT_S, END_S = 0.3, 0.5, 2.5
OUT = Path(__file__).resolve().parent.parent / "herzog_push_response.png"
MODES = {"pd": "PD", "lqr": "LQR (paper's cost)", "lqr_talos": "LQR (Talos cost)"}


def respond(mode: str) -> dict[str, np.ndarray]:
    """Time series of one push under momentum law `mode`: t (s), push force (N), CoG error (m,
    3 axes), linear and angular momentum (3 axes each)."""
    session = Session(SessionConfig(robot="talos"))
    for verb, payload in (("stack", {"preset": "herzog_table2"}), ("momentum", {"mode": mode})):
        reply = session.handle(verb, payload)
        assert reply["ok"], reply
    rows = []
    pushed = False
    while session.time < END_S - 1e-9:
        if not pushed and session.time >= PUSH_AT_S - 1e-9:
            payload = {"body": session.robot.base_link, "force": PUSH_FORCE.tolist()}
            session.handle("push", {**payload, "duration": PUSH_DURATION})
            pushed = True
        force = sum((p.force for p in session.pushes.values()), np.zeros(3))
        session.tick()
        if session.time >= SETTLE_S:
            h = session.model.centroidal_momentum()
            error = session.model.com - session.controller.references.com
            rows.append(np.concatenate(([session.time], force, error, h)))
    data = np.array(rows)
    assert not session.fell, f"{mode}: fell"
    return {
        "t": data[:, 0],
        "force": data[:, 1:4],
        "cog": data[:, 4:7],
        "linear": data[:, 7:10],
        "angular": data[:, 10:13],
    }


def plot_column(axes, series: dict[str, np.ndarray], panels: tuple, title: str) -> None:
    """One column of panels: for each (key, scale, label) of `panels`, the 3 axes of
    series[key] (times scale) against series["t"], one axes of `axes` each, under `title`."""
    for ax, (key, scale, label) in zip(axes, panels, strict=True):
        for axis, name in enumerate(("x", "y", "z")):
            ax.plot(series["t"], scale * series[key][:, axis], label=name, linewidth=1.0)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_title(title)
    axes[-1].set_xlabel("time [s]")


def save(fig, title: str, out: Path, dpi: int) -> None:
    """Title, lay out and write `fig` to `out`."""
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=dpi)
    print(f"wrote {out}")


def main() -> None:
    """Simulate both laws and save the figure."""
    fig, axes = plt.subplots(4, len(MODES), sharex=True, sharey="row", figsize=(14, 9))
    panels = (
        ("cog", 100.0, "CoG error [cm]"),
        ("linear", 1.0, "linear momentum [kg m/s]"),
        ("angular", 1.0, "angular momentum [kg m²/s]"),
        ("force", 1.0, "push force [N]"),
    )
    for column, mode in enumerate(MODES):
        plot_column(axes[:, column], respond(mode), panels, f"{MODES[mode]} momentum control")
    axes[0, 0].legend(loc="upper right")
    title = "Talos, Table 2 stack: 293 N for 32 ms (9.5 N s) at the pelvis from the front"
    save(fig, title, OUT, 90)


if __name__ == "__main__":
    main()
