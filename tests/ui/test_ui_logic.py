"""Pure logic of the browser lab: stack edits, joystick mapping, colours, drag spring, buffers,
typed numbers, the event log, the status line; and the drawn robot's frames against the sim's."""

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lab.description import ROBOT_NAMES, load_description
from lab.protocol import VelocityCommand
from lab.robot import build_robot
from lab.ui import stack_edit as se
from lab.ui.balance_controls import GAIN_ERRORS, GAIN_RATES, BalanceControls, gain_markdown
from lab.ui.camera import followed, recentred
from lab.ui.colors import friction_usage, usage_colour
from lab.ui.drag_push import Spring, spring_force
from lab.ui.event_log import CATEGORIES, EventLog, log_server_event
from lab.ui.gaits import gait_options
from lab.ui.guard_rails import error_growth, stack_risks, standing_risks
from lab.ui.joystick import JoystickLimits, from_offset, tap
from lab.ui.lab_lock import LabLock
from lab.ui.numbers import NumberError, NumberRange, format_number
from lab.ui.ownership import ControlOwnership
from lab.ui.panel import banner
from lab.ui.plot_buffer import RollingBuffer
from lab.ui.plot_export import Shown, shown_csv, shown_png
from lab.ui.push_controls import default_push_newtons
from lab.ui.status import (
    LiveStatus,
    LoopFigures,
    LoopWindow,
    RealtimeFactor,
    on_time_text,
    started_warnings,
    status_markdown,
    warnings_of,
)
from tests.helpers.ui import _SessionHost

STACK = [["contacts"], ["base_orientation", "com"], ["posture"]]


def test_move_to_level_above_and_below():
    assert se.move_to_level_above(STACK, "com") == [
        ["contacts", "com"],
        ["base_orientation"],
        ["posture"],
    ]
    assert se.move_to_level_below(STACK, "com") == [
        ["contacts"],
        ["base_orientation"],
        ["posture", "com"],
    ]
    # a task alone in its level: the level disappears
    assert se.move_to_level_above(STACK, "posture") == [
        ["contacts"],
        ["base_orientation", "com", "posture"],
    ]
    # at the ends a new level is made
    assert se.move_to_level_above(STACK, "contacts") == STACK
    assert se.move_to_level_below(STACK, "posture") == STACK
    assert se.move_to_level_above(STACK, "base_orientation")[0] == ["contacts", "base_orientation"]


def test_new_level_within_level_and_enable_disable():
    assert se.move_to_new_level(STACK, "com", above=True) == [
        ["contacts"],
        ["com"],
        ["base_orientation"],
        ["posture"],
    ]
    assert se.move_to_new_level(STACK, "com", above=False)[2] == ["com"]
    assert se.move_within_level(STACK, "com", -1)[1] == ["com", "base_orientation"]
    assert se.move_within_level(STACK, "com", +5)[1] == ["base_orientation", "com"]
    off = se.disable_task(STACK, "posture")
    assert off == [["contacts"], ["base_orientation", "com"]]
    assert se.enable_task(off, "posture", 2) == STACK
    assert se.enable_task(off, "posture", 0)[0] == ["contacts", "posture"]
    assert STACK == [["contacts"], ["base_orientation", "com"], ["posture"]]  # input untouched
    with pytest.raises(ValueError, match="'nope'"):
        se.move_to_level_above(STACK, "nope")
    with pytest.raises(ValueError, match="already"):
        se.enable_task(STACK, "com", 0)


def test_joystick_offset_mapping():
    lim = JoystickLimits(max_vx=0.6, max_vy=0.4, radius=0.3, deadzone=0.02)
    assert from_offset(0.015, -0.01, 0.0, lim) == VelocityCommand(0.0, 0.0, 0.0)
    full = from_offset(0.5, 0.0, 0.0, lim)
    assert full.vx == pytest.approx(0.6) and full.vy == 0.0
    half = from_offset(0.0, -0.16, 0.0, lim)  # (0.16 - 0.02) / 0.28 = 0.5 of max, to the right
    assert half.vy == pytest.approx(-0.2) and half.vx == 0.0
    diag = from_offset(1.0, 1.0, 5.0, lim)  # saturates, keeps direction, yaw clamped
    assert diag.vx / lim.max_vx == pytest.approx(math.sqrt(0.5))
    assert diag.yaw_rate == lim.max_yaw_rate


def test_joystick_taps_step_and_clamp():
    lim = JoystickLimits(max_vx=0.6, step_fraction=0.25)
    cmd = VelocityCommand()
    for _ in range(6):
        cmd = tap(cmd, "vx", 1, lim)
    assert cmd.vx == pytest.approx(0.6)
    cmd = tap(tap(cmd, "yaw_rate", -1, lim), "vx", -1, lim)
    assert cmd.vx == pytest.approx(0.45) and cmd.yaw_rate == pytest.approx(-0.25)
    assert cmd.payload() == {"vx": cmd.vx, "vy": 0.0, "yaw_rate": cmd.yaw_rate}
    with pytest.raises(ValueError, match="axis"):
        tap(cmd, "vz", 1, lim)


def test_friction_usage_and_colour():
    n = np.array([0.0, 0.0, 1.0])
    assert friction_usage(np.array([3.0, 4.0, 10.0]), n, 1.0) == pytest.approx(0.5)
    assert friction_usage(np.array([0.0, 0.0, 10.0]), n, 0.7) == 0.0
    assert friction_usage(np.array([1.0, 0.0, -1.0]), n, 0.7) == math.inf
    green, red = usage_colour(0.0), usage_colour(1.0)
    assert green[1] > green[0] and red[0] > red[1]
    assert usage_colour(math.inf) == red == usage_colour(3.0)
    mid = usage_colour(0.5)
    assert mid[0] > 200 and mid[1] > 180  # yellow


def test_spring_force_direction_and_cap():
    s = Spring(stiffness=400.0, max_force=300.0)
    f = spring_force(np.zeros(3), np.array([0.1, 0.0, 0.0]), s)
    np.testing.assert_allclose(f, [40.0, 0.0, 0.0])
    f = spring_force(np.array([1.0, 1.0, 1.0]), np.array([1.0, 3.0, 1.0]), s)
    np.testing.assert_allclose(f, [0.0, 300.0, 0.0])


def test_rolling_buffer_window_ring_and_rewind():
    b = RollingBuffer(2, window=1.0, capacity=50)
    for k in range(300):
        b.append(k * 0.01, [k, -k])
    t, y0, y1 = b.arrays()
    assert t[0] >= 2.99 - 1.0 - 1e-9 and t[-1] == pytest.approx(2.99)
    assert len(t) <= 50 and np.all(np.diff(t) > 0)
    np.testing.assert_allclose(y1, -y0)
    n = len(b)
    b.append(2.95, [7, 7])  # out of order (a telemetry message overtaken): dropped, kept sorted
    assert len(b) == n and b.arrays()[0][-1] == pytest.approx(2.99)
    b.append(0.5, [1, 1])  # clock rewound by a reset
    assert len(b) == 1
    with pytest.raises(ValueError, match="expected 2"):
        b.append(0.6, [1, 2, 3])


def test_gait_options_keep_the_experiments_out_unless_one_runs():
    gaits = ["stand", "height_step", "forward_shift", "trot", "crawl", "static_walk"]
    assert gait_options(gaits, "stand") == ("stand", "trot", "crawl")
    assert gait_options(gaits, "crawl") == ("stand", "trot", "crawl")
    # a scenario started an experiment: the dropdown still shows what runs
    assert gait_options(gaits, "height_step") == ("stand", "trot", "crawl", "height_step")
    assert gait_options([*gaits, "biped_step"], "stand")[-1] == "biped_step"
    assert gait_options(["stand"], "stand") == ("stand",)


def test_control_ownership():
    c = ControlOwnership()
    assert c.claim_if_free(1) and not c.claim_if_free(2)
    assert c.take(2) == 1 and c.is_owner(2) and not c.is_owner(1)
    assert not c.release(1) and c.release(2) and c.owner is None


class _Lab:
    """A lab's control lock as the server keeps it, for `LabLock`'s `request`."""

    def __init__(self) -> None:
        self.holder: str | None = None
        self.asked: list[str] = []

    def request(self, client: str, verb: str) -> dict:
        self.asked.append(verb)
        if verb == "take":
            if self.holder not in (None, client):
                return {"ok": False, "error": f"take: client {self.holder} holds the control lock"}
            self.holder = client
        elif self.holder == client:
            self.holder = None
        return {"ok": True, "control": {"holder": self.holder}}


def test_the_page_takes_the_labs_lock_only_to_act_and_reads_who_else_holds_it():
    lab = _Lab()
    lock = LabLock("ui-1", lambda verb: lab.request("ui-1", verb))
    assert lock.other() is None and not lock.seen({"t": 0.0})  # a message without `control`
    assert lock.acquire() is None and lab.holder == "ui-1"
    assert lock.acquire() is None and lab.asked == ["take"]  # held: no second take
    # telemetry built before the take still says "free": nothing to show, the page keeps it
    assert not lock.seen({"control": {"holder": None}}) and lock.other() is None
    lock.seen({"control": {"holder": "ui-1"}})
    lock.release()
    assert lab.holder is None and lab.asked == ["take", "release"]
    lock.release()  # not held: nothing asked
    assert lab.asked == ["take", "release"]
    lab.holder = "teleop-9"  # a terminal teleop takes it
    assert lock.seen({"control": {"holder": "teleop-9"}}) and lock.other() == "teleop-9"
    assert lock.acquire() == "client teleop-9 holds the control lock"  # refused, holder named
    lock.release()  # not the page's: left alone
    assert lab.holder == "teleop-9"
    lab.holder = None
    assert lock.seen({"control": {"holder": None}}) and lock.other() is None
    assert lock.acquire() is None and lab.holder == "ui-1"


def test_the_control_banner_names_the_browser_or_the_client_holding_control():
    assert banner(1, 1, None) == "**You hold control** of the robot."
    mine_locked = banner(1, 1, "teleop-9")
    assert mine_locked.startswith("**Read-only**") and "`teleop-9` holds the lab's" in mine_locked
    assert "Take control" in mine_locked
    assert banner(2, 1, None).startswith("**Read-only**: browser #1 holds control")
    assert "teleop-9" in banner(2, 1, "teleop-9")
    assert banner(2, None, None) == "Nobody holds control: press *Take control*."


def test_support_polygon_hull_and_degenerate_cases():
    from lab.ui.support import polygon_bounds, sole_corners, support_polygon

    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0]], float)
    hull = support_polygon(square)
    assert len(hull) == 4 and [0.5, 0.5, 0] not in hull.tolist()
    x = hull[:, 0] - 0.5
    y = hull[:, 1] - 0.5
    assert np.all(np.diff(np.unwrap(np.arctan2(y, x))) > 0)  # counter-clockwise
    line = support_polygon(np.array([[0, 0, 0], [2, 0, 0], [1, 0, 0]], float))
    assert sorted(line[:, 0].tolist()) == [0.0, 2.0]
    assert polygon_bounds(hull) == (0.0, 1.0, 0.0, 1.0)
    yaw90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    corners = sole_corners(np.array([1.0, 0.0, 0.0]), yaw90, 0.1, 0.05)
    assert polygon_bounds(corners) == pytest.approx((0.95, 1.05, -0.1, 0.1))


GAIN = NumberRange("kp", 0.0, 1e5)


@pytest.mark.parametrize(
    ("text", "value"), [("100", 100.0), (" 1e3 ", 1000.0), ("0", 0.0), ("2.5e-3", 0.0025)]
)
def test_typed_numbers_are_read_exactly_as_typed(text: str, value: float) -> None:
    assert GAIN.parse(text) == value


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("-5", "kp = -5 is below the limit 0"),
        ("1e9", "kp = 1e+09 is above the limit 100000"),
        ("1000000000", "kp = 1e+09 is above the limit 100000"),
        ("nan", "kp must be a finite number"),
        ("inf", "kp must be a finite number"),
        ("12abc", "kp: '12abc' is not a number"),
        ("", "kp: '' is not a number"),
    ],
)
def test_out_of_range_or_malformed_numbers_are_refused_naming_the_limit(
    text: str, message: str
) -> None:
    with pytest.raises(NumberError) as error:
        GAIN.parse(text)
    assert message in str(error.value)


def test_open_lower_bound_and_units_in_messages() -> None:
    weight = NumberRange("weight", 0.0, 1e8, lo_open=True)
    with pytest.raises(NumberError, match="weight = 0 must be above 0"):
        weight.check(0.0)
    assert weight.check(1e-8) == 1e-8
    push = NumberRange("Magnitude", 10.0, 600.0, "N")
    with pytest.raises(NumberError, match="Magnitude = 5 N is below the limit 10 N"):
        push.check(5.0)


@pytest.mark.parametrize("value", [1e9, 100.0, 0.001, 1e-5, 123456789.0, 0.1 + 0.2, 1e-8])
def test_a_number_box_shows_text_that_reads_back_to_the_same_number(value: float) -> None:
    assert float(format_number(value)) == value


def test_event_log_is_newest_first_and_counts_repeats() -> None:
    log = EventLog(size=3)
    log.add("info", "reset", wall=0.0)
    log.add("error", "fall", wall=1.0)
    log.add("error", "fall", wall=2.0)
    assert [e.text for e in log.entries()] == ["fall", "reset"]
    assert "fall (×2)" in log.markdown().splitlines()[2]
    for k in range(3):
        log.add("warning", f"w{k}", wall=3.0 + k)
    assert [e.text for e in log.entries()] == ["w2", "w1", "w0"]  # bounded
    with pytest.raises(ValueError, match="'loud'"):
        log.add("loud", "x")
    with pytest.raises(ValueError, match="'noise'"):
        log.add("info", "x", category="noise")


def test_a_warning_that_comes_and_goes_keeps_one_line_and_pushes_nothing_out() -> None:
    log = EventLog(size=3)
    log.add("error", "kp = -5 is below the limit 0", wall=0.0)
    for k in range(50):  # the sim falls behind real time and catches up, again and again
        log.add("warning", f"t {k:.2f} s · the sim runs at 0.8× real time", wall=k, kind="behind")
        if k == 25:
            log.add("info", "pushed forward", wall=k + 0.5)
    texts = [e.text for e in log.entries()]
    assert texts == [
        "t 49.00 s · the sim runs at 0.8× real time",
        "pushed forward",
        "kp = -5 is below the limit 0",
    ]
    assert "(×50)" in log.markdown().splitlines()[2]


def test_overruns_take_one_line_with_count_and_rate_and_the_session_is_kept_by_kind() -> None:
    """An hour of overrun reports (one a second, as the loop sends them) keeps one line, updated
    in place; the pushes, refusals, falls and resets of that hour all stay, filterable."""
    log = EventLog()
    events = {"push": 0, "refusal": 0, "fall": 0, "reset": 0}
    for k in range(3600):
        event = {"type": "overrun", "t": k, "message": "3 tick(s) overran", "count": 3}
        log_server_event(log, event, wall=1000.0 + k)
        if k % 60 == 0:
            log.add("info", f"pushed forward: 50 N #{k}", wall=1000.0 + k, category="push")
            log_server_event(log, {"type": "rejected_command", "t": k, "message": "kp"})
            log_server_event(log, {"type": "fall", "t": k, "message": "the robot fell"})
            log_server_event(log, {"type": "reset", "t": k, "message": "reset"})
            for category in events:
                events[category] += 1
    (overrun,) = log.recurring()
    assert (overrun.count, overrun.events) == (3 * 3600, 3600)
    assert overrun.rate(now=1000.0 + 3599) == pytest.approx(3.0)  # 3 ticks a second lately
    assert overrun.rate(now=1000.0 + 3700) == 0.0  # and none once they stopped
    text = log.markdown(now=1000.0 + 3599)
    assert text.count("overrun") == 1 and "10,800 since" in text and "3.0/s" in text
    for category, n in events.items():
        assert len(log.entries(category)) == n, category
        shown = log.markdown(category)
        assert f"Events ({category}), newest first ({n} kept)" in shown
        others = [c for c in CATEGORIES if c not in (category, "info")]
        assert all(e.category == category for e in log.entries(category)), others
    assert len(log.entries()) == sum(events.values())


def test_events_of_many_threads_never_break_the_log() -> None:
    """Browser callbacks add while the render loop renders (it read "deque mutated during
    iteration")."""
    import threading

    log = EventLog()
    stop = threading.Event()

    def add() -> None:
        k = 0
        while not stop.is_set():
            log.add("info", f"line {k}", category="push")
            k += 1

    writer = threading.Thread(target=add)
    writer.start()
    try:
        for _ in range(300):
            log.markdown()
            log.entries("push")
    finally:
        stop.set()
        writer.join()


def test_realtime_factor_restarts_with_the_sim_clock() -> None:
    rtf = RealtimeFactor(window_s=2.0)
    for k in range(20):  # 1 s of sim per 1 s of wall
        rtf.add(0.1 * k, 50.0 + 0.1 * k, ("anymal", "flat"))
    assert rtf.value() == pytest.approx(1.0)
    rtf.add(2.0, 0.0, ("anymal", "flat"))  # reset: the sim clock went back to 0
    assert math.isnan(rtf.value())  # one sample: no statistic yet, never -25
    rtf.add(2.5, 0.25, ("anymal", "flat"))
    assert rtf.value() == pytest.approx(0.5)
    rtf.add(3.0, 0.3, ("talos", "flat"))  # a switch starts again even if the clock went on
    assert math.isnan(rtf.value())


def test_a_starved_page_times_its_figures_by_the_loops_clock() -> None:
    """A UI process short of CPU receives telemetry in bursts. The loop keeps real time with 90 %
    of its ticks on time (its clock and counters say so); the page received the messages of
    the last 4 s in the last 0.5 s. Timed by receipt it showed 3.3× real time; timed by the
    loop's `clock_s` it shows the loop's own figures. A replay (not live) keeps receipt time."""

    def message(k: int) -> dict:
        loop = {"ticks": 100 * k, "on_time_fraction": 0.9, "overruns": 0, "clock_s": 0.1 * k}
        return {"t": 0.1 * k, "loop": loop, "qp": {"solve_us": 50.0}}

    def received(k: int) -> float:  # on time for 1 s, then 4 s of messages in 0.5 s
        return 0.1 * k if k <= 10 else 1.0 + (k - 10) * 0.5 / 40

    live, replay = LiveStatus(), LiveStatus()
    for k in range(51):
        live.add_newest(100.0 + received(k), message(k), ("bolt", "flat"))
        replay.add_newest(100.0 + received(k), message(k), ("bolt", "flat"), live=False)
    assert live.rtf.value() == pytest.approx(1.0)
    window = live.loop.window()
    assert window is not None and window.on_time_fraction == pytest.approx(0.9)
    assert window.seconds == pytest.approx(5.0)
    assert replay.rtf.value() == pytest.approx(10 / 3)  # by receipt: what the page showed


def _telemetry(**changes) -> dict:
    tel = {
        "t": 1.0,
        "robot": "talos",
        "scene": "flat",
        "gait": "stand",
        "paused": False,
        "fell": False,
        "hierarchy": {"method": "nullspace", "solver": "daqp", "formulation": "qdd_force"},
        "status": {"status": "ok", "level": None, "reason": ""},
        "qp": {"solve_us": 400.0, "failures": 0},
        "loop": {"rate_hz": 1000.0, "realtime": True, "on_time_fraction": 1.0},
    }
    tel.update(changes)
    return tel


def test_status_line_names_the_running_robot_and_is_ok_only_when_all_is_well() -> None:
    text = status_markdown(_telemetry(), rtf=1.0, fps=30.0)
    assert text.startswith("**talos** on flat")
    assert "(ok)" in text and "⚠" not in text
    assert warnings_of(_telemetry()) == {}


def test_status_line_warns_of_slow_ticks_fallbacks_falls_and_a_slow_sim() -> None:
    slow = _telemetry(qp={"solve_us": 80_000.0, "failures": 0})
    text = status_markdown(slow, rtf=0.01, fps=30.0)
    assert "(ok)" not in text and "(**slow**)" in text
    assert "80.0 ms per tick, over the 1.0 ms period" in text
    assert "0.01× real time" in text
    # the recent typical time decides, not one tick
    assert "slow" not in warnings_of(slow, control_us=500.0)
    failed = _telemetry(
        status={"status": "failed", "level": None, "reason": "QPFailure: daqp found no solution"},
        qp={"solve_us": 100.0, "failures": 3},
        fell=True,
    )
    assert set(warnings_of(failed)) == {"fallback", "fell"}
    assert "(**failed**)" in status_markdown(failed, rtf=1.0, fps=30.0)
    # after Reset the telemetry says not fallen: nothing stale is left
    assert "fell" not in status_markdown(_telemetry(), rtf=1.0, fps=30.0)
    paused = _telemetry(paused=True)
    assert "behind" not in warnings_of(paused, rtf=0.0)  # a paused sim is not slow


def test_status_line_shows_what_ran_and_the_status_with_its_level_and_reason() -> None:
    """The four fields of `ran` (not the request of `hierarchy`), and a status other than ok
    with the level and reason telemetry carries."""
    ran = {"kernel": "python", "method": "weighted", "solver": "clarabel"}
    ran |= {"formulation": "qdd_force", "note": "solver 'clarabel' runs on the Python kernel"}
    tel = _telemetry(
        ran=ran,
        kernel="python",
        status={"status": "fallback", "level": 2, "reason": "the QP of level 2 failed"},
    )
    text = status_markdown(tel, rtf=1.0, fps=30.0)
    assert "weighted/clarabel · python kernel" in text and "nullspace" not in text
    assert "(**fallback**)" in text
    assert "controller fallback at level 2: the QP of level 2 failed" in text
    assert "python kernel ran: solver 'clarabel' runs on the Python kernel" in text
    violated = {"status": "violated", "level": 0, "reason": "level 0 friction: exceeded by 2.5"}
    assert "(**violated**)" in status_markdown(_telemetry(status=violated), rtf=1.0, fps=30.0)


def test_status_line_warns_of_a_controller_warning_and_the_log_gets_it_once() -> None:
    cap = {"kind": "ActiveSetCapWarning", "message": "active set stopped at the cap", "t": 1.0}
    capped = _telemetry(controller_warnings=[{**cap, "ticks": 3}])
    text = status_markdown(capped, rtf=1.0, fps=30.0)
    assert "(ok)" not in text and "(**warning**)" in text
    assert "⚠ controller warning: active set stopped at the cap" in text
    in_effect: set[str] = set()
    logged = []
    for tel in (capped, capped, _telemetry(), capped):  # logged when it starts, not every frame
        now = warnings_of(tel)
        logged += [text for _, text in started_warnings(now, in_effect)]
        in_effect = set(now)
    assert logged == ["controller warning: active set stopped at the cap"] * 2
    note = "the native kernel has no method 'nullspace'"
    fell_back = _telemetry(kernel="python", kernel_note=note)
    assert f"python kernel ran: {note}" in status_markdown(fell_back, rtf=1.0, fps=30.0)
    assert "nullspace (qdd_force)/daqp · native kernel" in status_markdown(
        _telemetry(kernel="native", kernel_note=""), rtf=1.0, fps=30.0
    )


def test_the_live_on_time_figure_is_over_the_last_seconds_and_marked_below_its_target() -> None:
    """Under `nullspace` the session figure read 73.9 % while 1.9 % of recent ticks were on
    time: the status line shows both, the recent one marked, and warns of the collapse."""
    figures = LoopFigures(window_s=5.0)
    ticks, on_time = 100_000, 73_900  # the session so far
    for k in range(100):  # 10 s of telemetry, 1.9 % of the new ticks on time, 2 overruns a second
        ticks, on_time = ticks + 100, on_time + 1.9
        loop = {"ticks": ticks, "on_time_fraction": on_time / ticks, "overruns": 2 * (k // 10)}
        figures.add(0.1 * k, loop)
    window = figures.window()
    assert window is not None and window.seconds == pytest.approx(5.0)
    assert window.on_time_fraction == pytest.approx(0.019)
    assert window.overruns == 10
    tel = _telemetry(loop={"rate_hz": 1000.0, "realtime": True, **loop})
    text = status_markdown(tel, rtf=0.5, fps=30.0, loop=window, run_rtf=0.97)
    assert "on-time **1.9 %** last 5 s, **67.4 %** session (target 98 %)" in text
    assert "RTF **0.50** last 5 s, 0.97 run" in text
    assert set(warnings_of(tel, loop=window)) == {"overrun", "collapsed"}
    assert "10 tick(s) overran the 1 ms period in the last 5 s" in text
    quiet = LoopWindow(5.0, 5000, 0.995, 0)
    calm = status_markdown(_telemetry(), rtf=1.0, fps=30.0, loop=quiet, run_rtf=1.0)
    assert "on-time 99.5 % last 5 s" in calm and "**" not in calm.split("\n")[1]
    figures.add(11.0, {"ticks": 10, "on_time_fraction": 1.0, "overruns": 0})  # a new sim process
    assert figures.window() is None


def test_the_on_time_figure_is_shown_against_the_machines_floor_when_measured() -> None:
    """With `loop.floor` in telemetry the status line gives the floor, and marks a figure only
    when it is more than 0.3 points below it (the host's late wake-ups are not the lab's)."""
    floor = {"on_time_fraction": 0.982, "ticks": 2000, "seconds": 2.0}
    loop = {"rate_hz": 1000.0, "realtime": True, "ticks": 10_000, "on_time_fraction": 0.979}
    near = LoopWindow(5.0, 5000, 0.979, 0)
    text = on_time_text({**loop, "floor": floor}, near)
    assert text == "on-time 97.9 % last 5 s, 97.9 % session (this machine's floor 98.2 %)"
    far = on_time_text({**loop, "floor": floor}, LoopWindow(5.0, 5000, 0.970, 0))
    assert far.startswith("on-time **97.0 %** last 5 s, 97.9 % session")
    assert "(target 98 %)" in on_time_text(loop, LoopWindow(5.0, 5000, 0.970, 0))  # no floor


def test_a_control_time_beyond_its_share_of_the_period_is_marked_never_ok() -> None:
    """ "control 972 µs (ok)" was shown at 11 % on time: beyond 60 % of the period it is marked."""
    tel = _telemetry(qp={"status": "ok", "solve_us": 972.0, "failures": 0})
    text = status_markdown(tel, rtf=1.0, fps=30.0)
    assert "control 972 µs (**over 600 µs**)" in text and "(ok)" not in text
    assert "control 400 µs (ok)" in status_markdown(_telemetry(), rtf=1.0, fps=30.0)


def test_the_push_default_is_a_share_of_the_robots_weight() -> None:
    assert default_push_newtons(2.5) == 4.0  # Solo12 fell at 30 N (the old default was 150 N)
    assert default_push_newtons(50.0) == 74.0
    assert default_push_newtons(1e4) == 600.0  # the slider's top
    assert default_push_newtons(0.1) == 1.0  # and its bottom


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_drawn_robot_has_every_contact_frame_where_the_sim_has_it(viser_server, name) -> None:
    """The overlays look contact frames up in the state's frames (Talos's sole centres are
    frames the description adds): each must be there and sit where the controller's is; every
    link with a visual mesh gets a placement."""
    import pinocchio as pin

    from lab.robot import FramePlacements
    from lab.ui.robot_view import RobotView
    from lab.urdf_visuals import read_visuals

    desc = load_description(name)
    robot = build_robot(desc)
    view = RobotView(viser_server, desc)
    try:
        q = robot.q_standing
        frames = FramePlacements(robot).message(q)
        view.set_state(frames)
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, q)
        for contact in desc.contacts:
            sim = data.oMf[robot.model.getFrameId(contact.frame)]
            drawn = view.frame_placement(contact.frame)
            assert np.allclose(drawn.translation(), sim.translation, atol=1e-9), contact.frame
            assert np.allclose(drawn.rotation().as_matrix(), sim.rotation, atol=1e-9)
        links = {visual.link for visual in read_visuals(desc.urdf_path, desc.package_dirs)}
        assert links <= set(frames["names"])
        with pytest.raises(KeyError, match="no frame 'nope'"):
            view.frame_placement("nope")
    finally:
        view.remove()


@pytest.mark.parametrize("name", ["hyq", "bolt"])
def test_the_urdf_visuals_sit_where_pinocchio_puts_them(name) -> None:
    """The UI reads `<visual>` itself (no pinocchio in the UI process): at a bent posture each
    visual's world placement (link placement from the sim x URDF origin) and its shape, size and
    colour agree with pinocchio's geometry model. HyQ has boxes, cylinders, spheres, scaled
    meshes and named materials; Bolt inline colours."""
    import pinocchio as pin

    from lab.robot import FramePlacements
    from lab.urdf_visuals import read_visuals

    desc = load_description(name)
    robot = build_robot(desc)
    model = robot.model
    geometry = pin.buildGeomFromUrdf(
        model,
        str(desc.urdf_path),
        pin.GeometryType.VISUAL,
        package_dirs=[str(desc.package_dirs[0])],
    )
    q = robot.q_standing.copy()
    q[7:] += np.linspace(-0.3, 0.3, model.nq - 7)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    frames = FramePlacements(robot).message(q)
    poses = zip(frames["positions"], frames["quaternions"], strict=True)
    placement = dict(zip(frames["names"], poses, strict=True))
    visuals = read_visuals(desc.urdf_path, desc.package_dirs)
    assert len(visuals) == len(geometry.geometryObjects)
    by_name = {}
    for visual in visuals:
        by_name.setdefault(visual.link, []).append(visual)
    for geom in geometry.geometryObjects:
        link = model.frames[geom.parentFrame].name
        visual = by_name[link][int(geom.name.rsplit("_", 1)[1])]
        expected = data.oMi[geom.parentJoint] * geom.placement
        position, quaternion = placement[link]
        link_pose = pin.XYZQUATToSE3(np.array([*position, *quaternion]))
        drawn = link_pose * pin.SE3(visual.origin)
        assert np.allclose(drawn.homogeneous, expected.homogeneous, atol=1e-9), geom.name
        if visual.rgba is not None:
            assert np.allclose(visual.rgba, geom.meshColor), geom.name
        if visual.mesh is not None:
            assert str(visual.mesh) == geom.meshPath
            assert np.allclose(visual.size, geom.meshScale)


def test_the_ui_process_imports_neither_pinocchio_nor_mujoco_nor_the_server() -> None:
    """The UI is a Zenoh client that draws: every module of lab.ui imports only light parts of
    the lab (lab.protocol, lab.description, lab.scenes are plain data, lab.client_core its
    link), never the controller's pinocchio, the sim's MuJoCo or the server's side of Zenoh
    (lab.runtime: its configuration, queryable and publishers)."""
    code = (
        "import importlib, pkgutil, sys, lab.ui\n"
        "for m in pkgutil.iter_modules(lab.ui.__path__):\n"
        "    importlib.import_module('lab.ui.' + m.name)\n"
        "heavy = ('pinocchio', 'mujoco')\n"
        "server = ('lab.world', 'lab.runtime', 'lab.experiments', 'lab.recording')\n"
        "print(sorted(m for m in sys.modules\n"
        "             if m.split('.')[0] in heavy or m.startswith(server)))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert result.stdout.strip() == "[]", result.stdout


def test_the_camera_follows_the_base_horizontally_and_recentres() -> None:
    position, look_at = np.array([1.0, -1.0, 1.0]), np.array([0.0, 0.0, 0.3])
    moved = followed(position, look_at, np.array([0.4, 0.1, 0.45]))
    assert moved is not None  # the orbit (position - look_at) is kept, the height too
    assert np.allclose(moved[0], [1.4, -0.9, 1.0]) and np.allclose(moved[1], [0.4, 0.1, 0.3])
    assert followed(position, look_at, np.array([0.005, 0.0, 0.2])) is None
    # absolute: a stale camera (a report older than the last move) is still brought to the base
    again = followed(position, look_at, np.array([0.4, 0.1, 0.5]))
    assert again is not None and np.allclose(again[1], moved[1])
    camera, target = recentred(np.array([5.0, 2.0, 0.5]))
    assert np.allclose(target[:2], [5.0, 2.0]) and np.linalg.norm(camera - target) > 1.0


def test_guard_rails_warn_of_a_stack_without_contact_or_without_tasks() -> None:
    assert stack_risks([["contact"], ["com", "posture"]]) == []
    (no_contact,) = stack_risks([["com"], ["posture"]])
    assert no_contact.startswith("the robot will fall: no contact task")
    (nothing,) = stack_risks([])
    assert "every task is off" in nothing


def test_the_page_warns_of_a_stack_unlikely_to_stand() -> None:
    tasks = ["contact", "com", "posture", "swing_feet"]
    standing = [["friction"], ["contact"], ["com"], ["posture"]]
    assert standing_risks(standing, tasks, "stand") == []
    (risk,) = standing_risks([["friction", "posture"], ["contact"], ["com"]], tasks, "stand")
    assert risk.startswith("posture above the contact task")
    stepping = [["friction"], ["contact"], ["swing_feet"], ["com"]]
    assert standing_risks(stepping, tasks, "biped_step") == []
    assert "stepping stack" in standing_risks(stepping, tasks, "stand")[0]
    assert "no contact task" in standing_risks([["com"]], tasks, "stand")[0]


def test_a_fall_after_a_switch_names_the_tasks_that_lost_most() -> None:
    def tel(errors: dict[str, float]) -> dict:
        return {
            "tasks": [
                {"name": n, "level": i, "error": e} for i, (n, e) in enumerate(errors.items())
            ]
        }

    before = tel({"contact": 1e-9, "com": 1e-4, "posture": 0.01})
    after = tel({"contact": 1e-9, "com": 0.3, "posture": 0.02})
    assert error_growth(before, after, top=1) == "level 1 com 0.0001 → 0.3"
    assert error_growth(before, before) == "no task error grew"


def test_the_plots_export_is_the_shown_window_as_csv() -> None:
    t = np.array([1.0, 1.01, 1.02])
    forces = ("Contact normal force [N]", ("LF", "RF"), (t, np.array([1.0, 2.0, 3.0]), t * 0))
    qp = ("QP solve time [µs]", ("solve µs",), (t[1:], np.array([50.5, 60.0])))
    lines = shown_csv([forces, qp]).splitlines()
    assert lines[0] == (
        '"t [s]","Contact normal force [N]: LF","Contact normal force [N]: RF",'
        '"QP solve time [µs]: solve µs"'
    )
    assert lines[1:] == ["1.0,1.0,0.0,", "1.01,2.0,0.0,50.5", "1.02,3.0,0.0,60.0"]
    assert shown_csv([("empty", (), ()), ("portrait", ("path",), ())]).splitlines() == ['"t [s]"']


def test_the_plots_export_as_png_draws_one_panel_per_chart_with_data() -> None:
    import io

    from PIL import Image

    t = np.linspace(0.0, 1.0, 50)
    charts = [
        Shown("Contact normal force [N]", ("LF",), (t, 100 * np.sin(6 * t))),
        Shown("CoP vs support polygon [m]", ("CoP x",), (t, 0.1 * t)),
        Shown("QP solve time [µs]", (), ()),  # nothing recorded: no panel
    ]
    image = np.asarray(Image.open(io.BytesIO(shown_png(charts))).convert("L"))
    assert image.shape == (440, 700)  # two panels of 2.2 in × 7 in at 100 dpi
    for panel in (image[:220], image[220:]):  # each panel has its curve: dark pixels
        assert (panel < 128).sum() > 500
    empty = np.asarray(Image.open(io.BytesIO(shown_png([]))).convert("L"))
    assert empty.shape == (220, 700)


def test_the_panel_knows_the_app_only_through_its_narrow_host_interface() -> None:
    import ast
    import inspect

    from lab.ui import (
        number_fields,
        panel,
        panel_host,
        push_controls,
        stack_editor,
        velocity_controls,
    )
    from lab.ui.app import LabApp

    for module in (
        panel,
        panel_host,
        push_controls,
        stack_editor,
        velocity_controls,
        number_fields,
    ):
        imported = {
            node.module
            for node in ast.walk(ast.parse(inspect.getsource(module)))
            if isinstance(node, ast.ImportFrom)
        }
        assert "lab.ui.app" not in imported, module  # no import cycle between panel and app
    host = panel_host.PanelHost
    methods = [n for n, v in vars(host).items() if callable(v) and not n.startswith("_")]
    assert {"send", "report", "guard", "base_yaw"} <= set(methods)
    missing = [name for name in methods if not callable(getattr(LabApp, name, None))]
    assert not missing, f"LabApp lacks {missing} of PanelHost"


@pytest.mark.parametrize("kernel", ["python", "native"])
def test_the_per_level_chart_has_one_series_per_stack_level_of_the_live_session(kernel) -> None:
    from lab.ui.plots import CHARTS
    from lab.world.session import Session, SessionConfig

    session = Session(SessionConfig(robot="anymal", kernel=kernel))
    for _ in range(5):
        session.tick()
    tel = session.telemetry()
    (chart,) = [c for c in CHARTS if c.title.startswith("Solve time per level")]
    levels = len(tel["stack"])
    assert chart.labels_of(tel) == tuple(f"level {k}" for k in range(levels))
    times = chart.values_of(tel)
    assert len(times) == levels and all(t > 0.0 for t in times), times  # every level was timed
    assert chart.labels_of({**tel, "solution": None}) == ()  # fallback torques: no solution


def test_the_plots_forget_a_lab_left_behind(viser_server) -> None:
    """After `clear` (another lab shown) the charts hold only what came after it, even from a
    clock ahead of the old one, which the rewind check alone would keep beside the old data."""
    from lab.ui.plots import Plots

    plots = Plots(viser_server.gui, viser_server.gui.add_folder("plots"))
    qp = next(c for c in plots.charts if c.title.startswith("QP solve"))

    def message(t: float, us: float) -> dict:
        foot = {"name": "lf", "measured_force": [0, 0, 90], "position": [0, 0, 0], "active": True}
        zero = [0.0, 0.0, 0.0]
        return {
            "t": t,
            "qp": {"solve_us": us},
            "contacts": [foot],
            "cop": {"net": None},
            "momentum": {"linear": zero, "angular": zero},
            "tasks": [],
            "solution": {},
        }

    for t in (1.0, 1.01, 1.02):
        plots.record(message(t, 50.0))
    plots.draw()
    assert len(qp.buffer) == 3 and len(qp.shown[0]) == 3
    plots.clear()
    for t in (7.0, 7.01):  # the other lab's clock is ahead
        plots.record(message(t, 80.0))
    plots.draw()
    assert qp.shown[0].tolist() == [7.0, 7.01] and qp.shown[1].tolist() == [80.0, 80.0]
    forces = plots.charts[0]
    handle = forces._handle
    x_range = handle.scales["x"]["range"]
    assert x_range == (-10.0, 0.0) and handle.data[0].tolist() == pytest.approx([-0.01, 0.0])
    renamed = message(7.02, 80.0)  # another robot's feet: the same chart, its series replaced
    renamed["contacts"] = [{**renamed["contacts"][0], "name": "fl"}] * 2
    plots.record(renamed)
    plots.record({**renamed, "t": 7.03})
    plots.draw()
    assert forces._handle is handle and handle.visible
    assert [s["label"] for s in handle.series[1:]] == ["fl", "fl"] and len(handle.data) == 3


def test_the_momentum_gain_is_shown_as_a_table_row_per_error() -> None:
    gain = [[0.0] * len(GAIN_ERRORS) for _ in GAIN_RATES]
    gain[0][0], gain[1][3], gain[4][0] = 1270.0, 7.46, 1e-4  # ṗx←cx, ṗy←px, k̇y←cx (negligible)
    lines = gain_markdown(gain).splitlines()
    assert len(lines) == 2 + len(GAIN_ERRORS)  # header, rule, a row per error
    cells = [[c.strip() for c in line.split("|")[1:-1]] for line in lines[2:]]
    assert cells[0] == ["cx", "1270", "·", "·", "·", "·", "·"]
    assert cells[3] == ["px", "·", "7.46", "·", "·", "·", "·"]
    assert "no `momentum` task" in gain_markdown(None)


class _NoCommands:
    """A lab app for a folder that is only shown `info` (no button is pressed)."""

    def guard(self, callback):
        return callback

    def send(self, client, verb: str, payload: dict) -> None:
        raise AssertionError(f"{verb} sent: nothing was pressed")


def test_the_balance_folder_shows_the_current_laws_gain_from_info(viser_server) -> None:
    """The page shows K_h as it loads (from `info`), not only once a law is picked: Talos under
    Table 2 (PD: ṗx ← cx is m·kp) and then under a stack without the momentum task."""
    from lab.world.session import Session, SessionConfig

    session = Session(SessionConfig(robot="talos"))
    assert session.handle("stack", {"preset": "herzog_table2"})["ok"]
    assert session.handle("momentum", {"mode": "pd"})["ok"]
    folder = BalanceControls(_NoCommands(), viser_server.gui, order=99)
    folder.show_info(session.info())
    lines = folder.gain.content.splitlines()
    assert lines[0] == "Momentum law: pd" and lines[2].startswith("| K_h |")
    kp = session.controller.tasks["momentum"].gains.kp
    assert lines[4].split("|")[2].strip() == f"{session.model.mass * kp:.0f}"  # row cx, col ṗx
    assert session.handle("robot", {"name": "talos"})["ok"]  # its default stack
    folder.show_info(session.info())
    assert "no `momentum` task" in folder.gain.content


def test_a_push_button_pushes_the_robot_the_way_it_names_and_herzog_names_the_other_side() -> None:
    """The panel's buttons name the way the force pushes the robot, in its heading frame; Herzog
    2016's Table 3 scenarios (Talos facing +x) name the side the pusher stands on: each of their
    pushes "from the <side>" is the button of the opposite way."""
    from lab.ui.push_controls import PUSH_DIRECTIONS, push_force

    assert set(PUSH_DIRECTIONS) == {"forward", "backward", "left", "right"}
    for yaw, forward, left in ((0.0, (1, 0), (0, 1)), (math.pi / 2, (0, 1), (-1, 0))):
        ways = {"forward": forward, "left": left, "backward": np.negative(forward)}
        ways["right"] = np.negative(left)
        for button, (x, y) in ways.items():
            np.testing.assert_allclose(
                push_force(button, 100.0, yaw), [100 * x, 100 * y, 0], atol=1e-9
            )
    button_of = {"front": "backward", "back": "forward", "right": "left", "left": "right"}
    checked = 0
    for path in sorted((Path(__file__).parents[2] / "scenarios").glob("herzog_table3_*.toml")):
        side = None
        for line in path.read_text().splitlines():
            if heading := re.match(r"# (?:torso|hip), from the (\w+)", line):
                side = heading[1]
            elif side and (push := re.search(r"force = \[([^\]]+)\]", line)):
                force = np.array([float(f) for f in push[1].split(",")])
                expected = push_force(button_of[side], float(np.linalg.norm(force)), 0.0)
                np.testing.assert_allclose(force, expected, atol=1e-9, err_msg=f"{path}: {line}")
                checked += 1
    assert checked == 3 * 7 * 4  # three scenarios, 7 points, 4 pushes each


def test_the_internal_force_folder_sets_the_reference_and_its_gain(viser_server) -> None:
    """Kim's Fig. 6 from the page: shown while the internal_force task runs (Bolt's default
    stack has it), the reference and K_F reach the session; a bad number sends nothing."""
    from types import SimpleNamespace

    from lab.ui.internal_force_controls import InternalForceControls
    from lab.world.session import Session, SessionConfig

    session = Session(SessionConfig(robot="bolt"))
    host = _SessionHost(session)
    folder = InternalForceControls(host, viser_server.gui, order=99)
    folder.show_info(session.info())
    assert folder.folder.visible
    click = SimpleNamespace(client=object())
    folder.reference.value, folder.gain.value = "-20", "1e9"
    folder._apply(click)
    assert host.sent == [] and "K_F = 1e+09 is above the limit 100000" in folder.note.content
    folder.gain.value = "2.5"
    folder._apply(click)
    assert [verb for verb, _ in host.sent] == ["internal_force", "gains"]
    assert session.controller.internal_force.reference == -20.0
    gains = next(t for t in session.info()["tasks"] if t["name"] == "internal_force")
    assert gains["kp"] == 2.5 and folder.note.content.startswith("✔ reference -20 N, K_F 2.5")
    assert session.handle("robot", {"name": "anymal"})["ok"]
    folder.show_info(session.info())
    assert not folder.folder.visible  # no internal_force task in ANYmal's stack


def test_each_scene_set_up_is_installed_with_its_scene_and_bolt_holds_on_the_wedges() -> None:
    """The set-ups the page offers name scenes, presets and robots that exist; a `scene` command
    with `setup` installs every command of one before the scene's first tick (Kim's on Bolt:
    WBOSC, internal force 0.51 m g, K_F 1), and Bolt then stands on the split wedges, and again
    after a Reset, where without it it falls within a second. A scene without a set-up for the
    robot running is refused with `setup`, naming the ones it has, and nothing changes."""
    from lab.scenes import SCENES
    from lab.scenes.setups import SCENE_SETUPS
    from lab.stack_presets import PRESET_NAMES
    from lab.world.session import Session, SessionConfig

    for scene, setup in SCENE_SETUPS.items():
        assert scene in SCENES and set(setup.robots) <= set(ROBOT_NAMES), scene
        assert setup.preset is None or setup.preset in PRESET_NAMES
    talos = Session(SessionConfig(robot="talos"))
    reply = talos.handle("scene", {"name": "block", "setup": True})
    assert reply["ok"] and reply["setup"] == ["stack", "momentum"], reply
    assert talos.controller.momentum_mode().startswith("lqr") and talos.time == 0.0
    bolt = Session(SessionConfig(robot="bolt"))
    refused = bolt.handle("scene", {"name": "block", "setup": True})
    assert (
        not refused["ok"]
        and "no set-up for bolt (scenes with one for it: split_wedges)" in (refused["error"])
    )
    assert bolt.config.scene == "flat"
    assert bolt.handle("scene", {"name": "split_wedges"})["ok"]  # without it: Bolt falls
    while bolt.time < 1.0 and not bolt.fell:
        bolt.tick()
    assert bolt.fell, bolt.time
    reply = bolt.handle("scene", {"name": "split_wedges", "setup": True})
    assert reply["ok"] and reply["setup"] == ["hierarchy", "gains", "internal_force"], reply
    assert bolt.time == 0.0 and bolt.controller.config.method == "wbosc"  # before a tick
    internal = bolt.controller.internal_force
    assert internal.reference == pytest.approx(0.51 * bolt.model.mass * 9.81, abs=0.01)
    assert internal.gains.kp == 1.0
    for _ in range(2):
        start = bolt.time
        while bolt.time - start < 1.5 and not bolt.fell:
            bolt.tick()
        assert not bolt.fell, bolt.time
        assert bolt.handle("reset")["ok"]
    assert bolt.controller.config.method == "wbosc"  # Reset keeps the set-up


def test_only_viser_s_wakeup_race_is_taken_for_a_dropped_frame() -> None:
    """The render loop drops a frame (a warning) only for viser's own race, raised inside its
    message buffer; the same message raised by our code is still a UI error."""
    from lab.ui.render_loop import viser_wakeup_race

    def raised_in(filename: str) -> Exception:
        code = compile("raise RuntimeError('deque mutated during iteration')", filename, "exec")
        try:
            exec(code)
        except RuntimeError as error:
            return error
        raise AssertionError("no error raised")

    assert viser_wakeup_race(raised_in("/site-packages/viser/infra/_async_message_buffer.py"))
    assert not viser_wakeup_race(raised_in("/work/lab/ui/overlays.py"))
    assert not viser_wakeup_race(RuntimeError("something else"))
