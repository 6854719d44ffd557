"""Herzog 2016 §5.3: the CoG tracks a squat's sines under Table 2."""

import numpy as np
import pytest

from lab.controller.behaviours.squat import HOLD
from lab.server.session import Session, SessionConfig

# m: the CoG's largest distance from its moving reference (measured: 5.7 mm PD, 11.8 mm LQR,
# whose vertical stiffness with the paper's cost is 100 N/m), under half the 3 cm vertical sine.
TOLERANCE = 0.015


def test_a_bad_squat_period_is_refused() -> None:
    session = Session(SessionConfig(robot="talos"))
    reply = session.handle("gait", {"name": "squat", "cycle_time": 0.2})
    assert not reply["ok"] and "cycle_time" in reply["error"]
    assert session.behaviour.name == "stand"


@pytest.mark.parametrize("mode", ["pd", "lqr"])
def test_talos_squats_at_half_a_hertz(mode: str) -> None:
    """0.5 Hz, 2 cm forward and 3 cm vertical, one period: the CoG stays within TOLERANCE of its
    moving reference and goes down by at least 2 cm."""
    session = Session(SessionConfig(robot="talos"))
    assert session.handle("stack", {"preset": "herzog_table2"})["ok"]
    assert session.handle("momentum", {"mode": mode})["ok"]
    assert session.handle("gait", {"name": "squat", "cycle_time": 2.0})["ok"]
    start = session.model.com.copy()
    worst, lowest = 0.0, 0.0
    for _ in range(round(1000 * (HOLD + 2.0))):
        session.tick()
        error = session.model.com - session.controller.references.com
        worst = max(worst, float(np.linalg.norm(error)))
        lowest = min(lowest, float(session.model.com[2] - start[2]))
    assert not session.fell and session.qp_failures == 0
    assert worst < TOLERANCE
    assert lowest < -0.02
