"""B1-Z1's hand through the trot in place against the hands task's weight (issue 29): the
b1_z1_reach_circle_trot scenario (the hands task beside the moving posture in one level, the hand
on an 8 cm circle in the world) run whole at each weight, with the hand on the Z1's joints only
(`joints = "arm"`, robots/b1_z1.toml) and with all the robot's joints (`"all"`, as before).

    .venv/bin/python benchmarks/hand_weights.py [--weights 100 1000 10000] [--joints arm all]

Prints per run: whether it fell, the hand's largest and RMS error after 1 s (the hand_tracking
metric), and how far the trunk drifted horizontally from where it stood (m), the sign of a hand
that drags the base. Not a timing: the numbers are the simulation's, the same under any load.
"""

import argparse
import tomllib
from pathlib import Path

import numpy as np

from lab.experiments.metrics import METRICS
from lab.experiments.scenario import parse_scenario
from lab.world.session import Session

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "b1_z1_reach_circle_trot.toml"


def run(weight: float, joints: str) -> dict[str, float | bool]:
    """One whole run of the scenario at this hands weight and joints option."""
    data = tomllib.loads(SCENARIO.read_text())
    data["controller"]["gains"]["hands"]["weight"] = weight
    scenario = parse_scenario(data, SCENARIO)
    session = Session(scenario.config)
    controller = session.controller
    controller.set_hands(controller.hands, (joints,) * len(controller.hands))
    hand = METRICS["hand_tracking"](session)
    start = session.model.q[:2].copy()
    drift = 0.0
    pending = list(scenario.events)
    for _ in range(round(scenario.duration / scenario.config.timestep)):
        while pending and pending[0].t <= session.time + 1e-9:
            event = pending.pop(0)
            assert session.handle(event.verb, event.payload)["ok"]
        session.tick()
        hand.update(session)
        drift = max(drift, float(np.linalg.norm(session.model.q[:2] - start)))
        if session.fell:
            break
    result = hand.result()
    return {
        "fell": session.fell,
        "max": result["hand_error_max_m"],
        "rms": result["hand_error_rms_m"],
        "drift": drift,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--weights", type=float, nargs="+", default=[100, 300, 1000, 3000, 10000])
    parser.add_argument("--joints", nargs="+", choices=("arm", "all"), default=["arm", "all"])
    args = parser.parse_args()
    print("| joints | weight | fell | hand max (mm) | hand RMS (mm) | trunk drift (cm) |")
    print("|---|---:|---|---:|---:|---:|")
    for joints in args.joints:
        for weight in args.weights:
            r = run(weight, joints)
            print(
                f"| {joints} | {weight:g} | {'yes' if r['fell'] else 'no'} | "
                f"{1e3 * r['max']:.1f} | {1e3 * r['rms']:.1f} | {1e2 * r['drift']:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
