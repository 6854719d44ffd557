"""The native ticks of the behaviours other than walking and stepping (cpp/behaviours/
balance.cpp, line_balance.cpp, squat.cpp, stance.cpp, com_ellipse.cpp, body_motion.cpp,
static_walk.cpp, behind behaviour.hpp's one interface) against their Python updates, from the
same scripted inputs: Bolt's line balance on a moving state, Talos's squats and stance switches
with a leg swing, Bolt's CoM ellipse, ANYmal's height step, forward shift and static crawl.
Skipped when the kernel is not built."""

import functools
from collections.abc import Callable
from dataclasses import fields

import numpy as np
import pytest

from lab.controller.behaviours import BEHAVIOURS
from lab.controller.behaviours.balance import Balance
from lab.controller.behaviours.stance import LIFT_HEIGHT, Stance
from lab.controller.model import RobotModel
from lab.description import load_description
from lab.robot import Robot, build_robot
from lab.world.session import Session, SessionConfig
from tests.helpers.native_ticks import scripted_state, tick_native_and_mixed

pytest.importorskip("lab._kernel", reason="the native kernel is not built (./dev builds it)")

TOL = 1e-9  # relative to 1 + |value|: the same steps, another float order
# s between scripted ticks: the shortest phase scripted here (the crawl's 0.25 s force ramps)
# still gets 60 ticks, the swings and transitions 125-250
DT = 0.004
# The state between ticks of the behaviours here, as their Python classes name it.
SCALAR_STATE = ("start", "step", "stance", "_from", "_started", "_pending", "_swing")
SCALAR_STATE += ("_periods_done",)
ARRAY_STATE = ("_com_on_line", "_lifted", "feet", "lift_off", "com_start", "com_target")


@functools.cache
def robot(name: str) -> Robot:
    """The lab's robot `name` (its model, contacts and standing posture)."""
    return build_robot(load_description(name))


def first_feet(name: str) -> np.ndarray:
    """The feet (world, m) of robot `name` at the scripted state's start."""
    r = robot(name)
    model = RobotModel(r.model, r.contacts)
    model.update(*scripted_state(r.q_standing, 0.0))
    return model.contact_positions.copy()


def state_of(behaviour: object) -> dict[str, object]:
    """Every reference the behaviour writes, and its state between ticks (None as NaN, compared
    as −1 as the force weights' NaN)."""
    refs = behaviour.references
    values = {f.name: getattr(refs, f.name) for f in fields(refs)}
    state = vars(behaviour)  # the instance's attributes (not its methods: StaticWalk._swing)
    for name in SCALAR_STATE:
        if name in state:
            values[name] = np.nan if state[name] is None else state[name]
    for name in ARRAY_STATE:
        if name in state:
            values[name] = state[name]
    return values


def within_tol(actual: np.ndarray, reference: np.ndarray) -> bool:
    """Whether every entry of `actual` is the reference's (equal, both NaN, or within TOL ·
    (1 + the largest finite |reference|)): a quick check that accepts only what assert_same's
    assert_allclose accepts (whose NaN → −1 and ∞ → the largest float only widen it), so that
    the agreement tests, which compare every field every tick, do not spend most of their time
    in numpy.testing."""
    if actual.shape != reference.shape:
        return False
    finite = np.abs(reference[np.isfinite(reference)])
    atol = TOL * (1.0 + finite.max(initial=0.0))
    with np.errstate(invalid="ignore"):
        close = np.abs(actual - reference) <= atol
    return bool(np.all(close | (actual == reference) | (np.isnan(actual) & np.isnan(reference))))


def assert_same(native: object, python: object, tick: int) -> None:
    """The native behaviour's references and state equal the Python one's within TOL."""
    actual = state_of(native)
    for name, value in state_of(python).items():
        if isinstance(value, str | tuple) or np.asarray(value).dtype == bool:
            assert np.array_equal(np.asarray(actual[name]), np.asarray(value)), (name, tick)
            continue
        if within_tol(np.asarray(actual[name], dtype=float), np.asarray(value, dtype=float)):
            continue
        reference = np.nan_to_num(np.asarray(value, dtype=float), nan=-1.0)
        np.testing.assert_allclose(
            np.nan_to_num(np.asarray(actual[name], dtype=float), nan=-1.0),
            reference,
            rtol=0,
            atol=TOL * (1.0 + np.abs(reference).max(initial=0.0)),
            err_msg=f"{name} at tick {tick}",
        )


def run_three(
    name: str,
    make: Callable[[RobotModel, np.ndarray], object],
    seconds: float,
    script: Callable[[int, tuple], None] = lambda tick, behaviours: None,
    speed: float = 0.0,
) -> tuple:
    """Three behaviours made by `make` on robot `name`, given the same scripted state each tick
    (native_ticks.scripted_state), DT s apart: one runs every tick in Python, one natively, one
    alternating; `script(tick, behaviours)` acts on all three before a tick. Asserts they agree
    every tick; returns the Python one and the references' history (one state_of per tick)."""
    r = robot(name)
    model = RobotModel(r.model, r.contacts)
    model.update(*scripted_state(r.q_standing, 0.0, speed))
    behaviours = python, native, mixed = tuple(make(model, r.q_standing) for _ in range(3))
    assert native._native is not None, f"{type(native).__name__} has no native twin"
    command, touching = np.zeros(3), np.ones(len(r.contacts), dtype=bool)
    history = []
    for tick in range(round(seconds / DT)):
        t = 1.0 + tick * DT
        script(tick, behaviours)
        model.update(*scripted_state(r.q_standing, t, speed))
        python.update(t, model, command, touching)
        assert python.kernel_ran == "python"
        tick_native_and_mixed(tick, model, native, mixed, t, command, touching)
        assert native.kernel_ran == "native"
        assert_same(native, python, tick)
        assert_same(mixed, python, tick)
        history.append({k: np.copy(v) for k, v in state_of(python).items()})
    return python, history


def test_bolts_line_balance_agrees_and_leans_the_com_reference() -> None:
    """Bolt standing on its foot line, its state wobbling: the native line balance writes the
    Python one's CoM reference, which leans across the line one way and the other as the body
    rolls (over 0.1 mm each way), horizontally and within the law's 3 cm bound."""
    balance, history = run_three("bolt", Balance, 3.0)
    assert not balance.idle
    leans = np.array([h["com"] - balance._com_on_line for h in history])
    assert np.all(leans[:, 2] == 0.0)
    foot_line = np.diff(first_feet("bolt"), axis=0)[0]
    across = leans @ np.cross(foot_line / np.linalg.norm(foot_line), [0.0, 0.0, 1.0])
    assert across.min() < -1e-4 and across.max() > 1e-4
    assert np.abs(across).max() <= 0.03 + 1e-12


@pytest.mark.parametrize(("gait", "forward"), [("squat", 0.02), ("squat_cop", 0.045)])
def test_talos_squats_agree_through_a_change_of_period(gait: str, forward: float) -> None:
    """Talos's squat (and the CoP variant), its period changed mid-sine (the native state is read
    again): references equal every tick; the CoG reference swings by the amplitude."""

    def script(tick: int, behaviours: tuple) -> None:
        if tick == round(2.0 / DT):  # s
            for squat in behaviours:
                squat.configure(cycle_time=1.5)

    squat, history = run_three("talos", BEHAVIOURS[gait], 4.0, script)
    assert squat.period == 1.5
    x = np.array([h["com"][0] for h in history]) - squat.centre[0]
    assert x.max() == pytest.approx(forward, rel=1e-3)
    assert x.min() == pytest.approx(-forward, rel=1e-3)


def test_talos_stance_switches_and_swings_alike_in_both_kernels() -> None:
    """Talos: to the left sole, a 1 Hz swing of the lifted leg stopped after a period, then
    straight to the right sole (through double support): the transitions' CoG, force bounds,
    contacts, sole targets and the swing's joint references agree every tick; the right sole
    rises LIFT_HEIGHT and lands again, the left one rises last. Each transition takes 2.5 s
    (SHIFT_S + UNLOAD_S + LIFT_S); the script leaves 0.1-0.2 s between one's end and the next
    request (times in s from the start)."""
    at = {0.0: ("request", "left"), 2.6: ("swing", 1.0), 3.0: ("swing", 0.0)}
    at[3.8] = ("request", "right")  # the swing ends at 3.6 s, a period after it began
    requests = {round(t / DT): request for t, request in at.items()}

    def script(tick: int, behaviours: tuple) -> None:
        if tick in requests:
            verb, value = requests[tick]
            for stance in behaviours:
                getattr(stance, verb)(value)

    stance, history = run_three("talos", Stance, 9.0, script)
    right, left = (stance.names.index(side) for side in ("right", "left"))
    rise = np.array([h["sole_position"][:, 2] - stance._ground[:, 2] for h in history])
    assert rise[:, right].max() == pytest.approx(LIFT_HEIGHT)
    assert rise[round(2.55 / DT), right] == pytest.approx(LIFT_HEIGHT)  # on the left sole
    assert rise[round(5.0 / DT), right] == pytest.approx(0.0, abs=1e-12)  # landed at 4.8 s
    assert rise[-1, left] == pytest.approx(LIFT_HEIGHT)  # lifted from 6.3 s to 8.8 s
    swung = np.array([h["leg_swinging"] for h in history])
    assert swung[:, right].any() and not swung[-1].any()
    assert stance.stance == "right" and not stance.busy


def test_bolts_com_ellipse_agrees() -> None:
    """Bolt's CoM ellipse (Kim Fig. 6b) over one turn and more, on a wobbling state."""
    ellipse, history = run_three("bolt", BEHAVIOURS["com_ellipse"], 5.0)
    heights = [h["_com_on_line"][2] - ellipse.centre[2] for h in history]
    assert min(heights) == pytest.approx(-0.02, abs=1e-4)  # the ellipse's bottom: 2 A_z down


@pytest.mark.parametrize("gait", ["height_step", "forward_shift"])
def test_anymals_body_motions_agree(gait: str) -> None:
    """Hutter 2014 Exp6 and Exp7's scripted references on ANYmal, in both kernels."""
    motion, history = run_three("anymal", BEHAVIOURS[gait], 3.0)
    moved = history[-1]["com"] - motion.com
    assert np.linalg.norm(moved) == pytest.approx(0.08 if gait == "height_step" else 0.25)


@pytest.mark.parametrize("gait", ["static_walk", "static_walk_half_cylinder"])
def test_anymals_static_crawl_agrees(gait: str) -> None:
    """Hutter 2014 §5.1's crawl, on flat ground and in place on the half cylinder: the CoM
    shifts into each support triangle, the force weights ramp, the feet swing, in both kernels
    alike over a cycle of four steps; every foot lifts off."""
    walk, history = run_three("anymal", BEHAVIOURS[gait], 4 * 1.4 + 0.2)
    lifted = np.array([~h["contact_active"] for h in history])
    assert lifted.any(axis=0).all()
    weights = np.array([h["force_weight"] for h in history])
    assert np.nanmin(weights) >= 0.0 and np.nanmax(weights) <= 1.0
    assert walk.step == 4


def test_bad_behaviour_state_raises_a_clear_error_and_writes_nothing() -> None:
    r = robot("talos")
    model = RobotModel(r.model, r.contacts)
    model.update(*scripted_state(r.q_standing, 0.0))
    squat = BEHAVIOURS["squat"](model, r.q_standing)
    squat.centre = np.zeros(2)
    com = squat.references.com.copy()
    model.filled_elsewhere()
    with pytest.raises(ValueError, match="centre"):
        squat.update(1.0, model, np.zeros(3), np.ones(2, dtype=bool))
    assert np.array_equal(squat.references.com, com) and squat.start is None


def test_a_native_session_reports_the_native_behaviour_and_bolt_stands() -> None:
    """Bolt standing on the native kernel: its line balance runs natively, `ran` says so, and it
    stands 2 s."""
    session = Session(SessionConfig(robot="bolt"))
    for _ in range(2000):
        session.tick()
    assert session.controller.kernel_ran == "native"
    assert session.behaviour.kernel_ran == "native"
    assert session.telemetry()["ran"]["behaviour"] == "native"
    assert not session.fell and session.qp_failures == 0
