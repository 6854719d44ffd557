"""The realism layer's two kernels agree: lab/realism in Python and cpp/realism (lab._kernel's
RealismLayer) draw the same noise from the same seed and give the same measured states and
joint torques, to 1e-12, over a second of a moving robot's states."""

import numpy as np
import pytest

from lab.realism.knobs import preset
from lab.realism.layer import RealismLayer, realism_layer
from lab.world.session import Session, SessionConfig

_kernel = pytest.importorskip("lab._kernel")

DT = 1e-3
NA = 12
TICKS = 1000


def _true_states(rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """A smooth made-up motion: base turning and moving, joints swinging."""
    states = []
    for tick in range(TICKS):
        t = tick * DT
        angle = 0.3 * np.sin(2 * t)
        q = np.concatenate(([0.1 * t, 0.0, 0.5], [0, 0, np.sin(angle / 2), np.cos(angle / 2)]))
        q = np.concatenate((q, 0.4 * np.sin(3 * t + np.arange(NA))))
        v = np.concatenate(
            ([0.1, 0, 0, 0, 0, 0.6 * np.cos(2 * t)], 1.2 * np.cos(3 * t + np.arange(NA)))
        )
        states.append((q, v + 1e-3 * rng.normal(size=v.size)))
    return states


@pytest.mark.parametrize(
    ("name", "robot"), [("typical", "anymal"), ("typical", "hyq"), ("harsh", "anymal")]
)
def test_python_and_cpp_layers_give_the_same_numbers(name: str, robot: str) -> None:
    knobs = preset(name, robot)
    python, native = RealismLayer(knobs, NA, DT), _kernel.RealismLayer(knobs.values(), NA, DT)
    states = _true_states(np.random.default_rng(1))
    tau0 = np.linspace(-5, 5, NA)
    python.reset(states[0][0], tau0)
    native.reset(states[0][0], tau0)
    assert native.ideal == python.ideal is False
    worst = 0.0
    for tick, (q, v) in enumerate(states):
        (qp, vp), (qn, vn) = python.measure(q, v), native.measure(q, v)
        command = 20 * np.sin(5 * tick * DT + np.arange(NA))
        tp, tn = python.actuate(command, q, v), native.actuate(command, q, v)
        worst = max(worst, *(np.abs(a - b).max() for a, b in ((qp, qn), (vp, vn), (tp, tn))))
    assert native.tick == TICKS
    assert worst < 1e-12


def test_a_session_runs_the_cpp_layer_reports_it_and_ticks_as_the_python_one_does() -> None:
    """A session picks the C++ layer when lab._kernel is built and says so in telemetry; swapped
    for the Python layer, 300 ticks of ANYmal under `typical` give the same torques (to 1e-6
    N m: the layers agree to 1e-12, the closed loop amplifies that little in 0.3 s)."""
    knobs = preset("typical", "anymal")
    torques = {}
    for native in (True, False):
        session = Session(SessionConfig(robot="anymal", realism=knobs))
        if not native:
            session.realism = realism_layer(knobs, session.model.na, DT, native=False)
            session.realism.reset(session.robot.q_standing)
        assert session.telemetry()["realism"]["kernel"] == ("native" if native else "python")
        for _ in range(300):
            session.tick()
        torques[native] = session.tau.copy()
    np.testing.assert_allclose(torques[True], torques[False], atol=1e-6)
