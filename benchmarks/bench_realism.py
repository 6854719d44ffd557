"""The realism layer's cost per tick (docs/realism.md): the C++ layer alone (lab._kernel's
RealismLayer, what the native tick calls) and the Python reference, every knob on (`harsh` with
the SEA), the EKF alone (lab._kernel's EkfEstimator, four feet in contact), and the whole
session tick (ANYmal standing, native controller and plant) with realism ideal against typical
and against every knob on (the SEA, friction, saturation, model error and a 5 kg payload too;
with the EKF: `estimator = "ekf"`, and without), the layer and the EKF in C++ inside the native
tick (the session's default when lab._kernel is built), then typical on the Python tick with
the C++ and the Python layer; and ANYmal trotting at 0.5 m/s, where the touch sensing runs
(`contact_estimate`: the touch detector on the estimated contact forces, in C++ inside the
native tick), ideal, typical, typical with the contact estimate, and with the EKF as well.
Each row says which tick path ran (telemetry's `ran.tick`); the ratios are to the ideal tick
of the same motion (standing or trotting).

    .venv/bin/python benchmarks/bench_realism.py [--ticks N]

Prints median and p99 in µs per tick; run it on a quiet machine and quote `uptime` beside it.
"""

import argparse
import time
from collections.abc import Callable

import numpy as np

from lab import _kernel
from lab.realism.knobs import RealismKnobs, knobs_from, preset
from lab.realism.layer import RealismLayer, realism_layer
from lab.world.estimator import BaseEstimator
from lab.world.session import Session, SessionConfig

NA, DT = 12, 1e-3
CHUNK = 100  # ticks timed at a stretch per session


def _times(step: Callable[[], None], ticks: int) -> np.ndarray:
    out = np.empty(ticks)
    for i in range(ticks):
        start = time.perf_counter()
        step()
        out[i] = (time.perf_counter() - start) * 1e6
    return out


def _row(label: str, us: np.ndarray) -> float:
    median = float(np.median(us))
    print(f"{label:<60} median {median:8.2f} µs   p99 {np.percentile(us, 99):8.2f} µs")
    return median


def _ekf_alone(knobs: RealismKnobs, ticks: int) -> None:
    """The C++ EKF's read (accelerometer, predict, correct with four feet) on ANYmal standing."""
    session = Session(SessionConfig(robot="anymal"))
    robot, contacts = session.robot, np.ones(len(session.robot.contacts), dtype=bool)
    q, v = robot.q_standing, np.zeros(robot.model.nv)
    ekf = BaseEstimator(knobs_from(knobs, {"estimator": "ekf"}), robot, DT)
    ekf.reset(q, v)
    _row(
        "C++ EKF alone, four feet in contact (read)",
        _times(lambda: ekf.read((q, v), (q, v), contacts), ticks),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=5000)
    ticks = parser.parse_args().ticks
    sea = {"actuator": "sea", "sea_stiffness": 200.0, "sea_motor_inertia": 0.05}
    every = knobs_from(preset("harsh", "anymal"), {**sea, "sea_kp": 1800.0, "sea_kd": 10.0})
    q = np.concatenate(([0, 0, 0.5, 0, 0, 0, 1.0], np.zeros(NA)))
    v, tau = np.zeros(6 + NA), np.ones(NA)
    for kind, make in (("C++", _kernel.RealismLayer), ("Python", RealismLayer)):
        layer = make(every.values() if kind == "C++" else every, NA, DT)
        layer.reset(q, tau)

        def step(layer=layer) -> None:
            layer.measure(q, v)
            layer.actuate(tau, q, v)

        _row(f"{kind} layer, every knob on (measure + actuate)", _times(step, ticks))
    _ekf_alone(every, ticks)
    sessions = {}
    typical = preset("typical", "anymal")
    touch = knobs_from(typical, {"contact_estimate": 1})
    cases = (  # (motion, name, knobs, the C++ layer, native ticks)
        ("standing", "ideal", preset("ideal", "anymal"), True, True),
        ("standing", "typical", typical, True, True),
        ("standing", "every knob, EKF", knobs_from(every, {"estimator": "ekf"}), True, True),
        ("standing", "every knob, true estimator", every, True, True),
        ("standing", "typical", typical, True, False),
        ("standing", "typical", typical, False, False),
        ("trotting", "ideal", preset("ideal", "anymal"), True, True),
        ("trotting", "typical", typical, True, True),
        ("trotting", "typical, contact estimate", touch, True, True),
        (
            "trotting",
            "typical, contact estimate, EKF",
            knobs_from(touch, {"estimator": "ekf"}),
            True,
            True,
        ),
    )
    for motion, name, knobs, native_layer, native_ticks in cases:
        session = Session(SessionConfig(robot="anymal", realism=knobs))
        session.native_ticks = native_ticks
        session.realism = realism_layer(knobs, NA, DT, native=native_layer)
        session.realism.reset(session.robot.q_standing)
        if name.startswith("every knob"):
            assert session.handle("payload", {"body": "base", "mass": 5.0})["ok"]
        if motion == "trotting":
            assert session.handle("gait", {"name": "trot"})["ok"]
            assert session.handle("velocity", {"vx": 0.5})["ok"]
        for _ in range(200):
            session.tick()
        path = session.tick_report()["tick"]
        label = f"ANYmal {motion}, {name} ({session.realism.kernel} layer, {path} tick)"
        sessions[label] = session
    # in chunks of CHUNK ticks, the sessions in turn: a change of the host's load meets them all
    times = {label: [] for label in sessions}
    for _ in range(max(1, ticks // CHUNK)):
        for label, session in sessions.items():
            times[label].append(_times(session.tick, CHUNK))
    medians = {}
    for label, session in sessions.items():
        assert not session.fell, label
        medians[label] = _row(label, np.concatenate(times[label]))
    ideal = {}  # per motion, the first row's (its ideal tick)
    for label, median in medians.items():
        motion = label.split(",")[0]
        if motion not in ideal:
            ideal[motion] = median
            continue
        print(f"{label} / ideal: {median / ideal[motion]:.3f}")


if __name__ == "__main__":
    main()
