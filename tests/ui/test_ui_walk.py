"""The robot and scene walk in a real headless Chromium against a real `lab serve`: one page
switches to every robot the Robot dropdown offers and every scene of the Scene dropdown, and each
is drawn, takes a push and leaves the UI alive; then the page's console and the server's output
hold no error.

Its own server and browser (tests/ui/conftest.py), apart from tests/ui/test_ui_browser.py's: the
walk is the longest browser test (about 2 minutes on a worker), and in a file of its own
pytest-xdist's other worker runs it beside the rest of the page's tests (`./dev test`'s
`--dist loadfile`: a whole file per worker).
"""

import pytest

from lab.client import LabClient
from lab.description import ROBOT_NAMES
from lab.scenes import SCENE_ROBOTS, SCENES
from lab.ui.push_controls import default_push_newtons
from tests.helpers.browser import (
    PAGE_TIMEOUT_MS,
    LabServe,
    Pushes,
    choose,
    event_log,
    open_dropdown,
    press,
    slider_box,
    ui_alive,
    wait_drawn,
)

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.browser


def offered(page, label: str) -> list[str]:
    """The options of dropdown `label`, as the page lists them."""
    open_dropdown(page, label, page.get_by_role("option").first)
    names = page.get_by_role("option").all_inner_texts()
    page.keyboard.press("Escape")
    playwright_api.expect(page.get_by_role("option")).to_have_count(0)
    return [n.strip() for n in names]


def switch_draw_push(page, lab, serve, pushes, dropdown: str, value: str, robot: str) -> None:
    """Choose `value` in `dropdown`, wait until the sim runs it and `robot` is drawn, push, and
    check the UI is alive."""
    choose(page, dropdown, value)
    try:
        lab.wait_telemetry(lambda m: m[dropdown.lower()] == value, timeout=60.0)
    except TimeoutError:  # seen once at load 24: the sim never got the switch
        shown = page.get_by_label(dropdown, exact=True).first.input_value()
        assert shown != value, f"the page shows {value}, the sim never switched: {event_log(page)}"
        choose(page, dropdown, value)  # the option click was lost: a user clicks again
        lab.wait_telemetry(lambda m: m[dropdown.lower()] == value, timeout=60.0)
    wait_drawn(page, robot)
    if robot == "bolt":  # the page says how Bolt stands and how to make it step
        page.get_by_text("Bolt stands on its two point feet").first.wait_for()
    box = slider_box(page, "Magnitude [N]")
    if dropdown == "Robot":  # the push offered is a share of this robot's weight
        wanted = str(int(default_push_newtons(lab.command("info")["mass"])))
        playwright_api.expect(box).to_have_value(wanted, timeout=PAGE_TIMEOUT_MS)
    pushes.seen.clear()
    press(page, "forward")
    pushes.wait(float(box.input_value()))
    ui_alive(page, serve)


def for_anymal(scene: str) -> bool:
    """Is `scene` one ANYmal may stand in (not one made for another robot's feet)?"""
    return "anymal" in SCENE_ROBOTS.get(scene, ("anymal",))


# What the walk below leaves to another test that checks the same of it (drawn after the switch,
# its push, the UI alive), and which.
CHECKED_ELSEWHERE = {
    ("Robot", "bolt"): "tests/ui/test_bolt_browser.py: Bolt's page drawn, its note, its default "
    "push sent from the page and received, the UI alive",
    ("Scene", "split_wedges"): "tests/ui/test_bolt_browser.py: the switch from the page, Bolt "
    "drawn on the wedges",
    ("Scene", "balance_board_lateral"): "balance_board: the same floor and one hinged board "
    "(lab/scenes/balance_board.py, only its axis differs), drawn by the same TerrainView code",
}


def test_every_robot_and_scene_switches_draws_takes_a_push_and_the_ui_lives(
    page, lab: LabClient, serve: LabServe, pushes: Pushes, subtests
) -> None:
    """One page walks every robot the Robot dropdown offers (ANYmal last) and then every scene
    of the Scene dropdown with ANYmal (flat last; not the scenes made for another robot's feet),
    but those CHECKED_ELSEWHERE: one server and page for all, the switches being what is
    tested."""
    info = lab.command("info")
    assert (info["robots"], info["scenes"]) == (list(ROBOT_NAMES), list(SCENES))
    robots, scenes = offered(page, "Robot"), offered(page, "Scene")
    assert (robots, scenes) == (list(ROBOT_NAMES), list(SCENES))
    assert {value for _, value in CHECKED_ELSEWHERE} <= {*robots, *scenes}
    walk = [("Robot", r, r) for r in robots if r != "anymal"] + [("Robot", "anymal", "anymal")]
    walk += [("Scene", s, "anymal") for s in scenes if s != "flat" and for_anymal(s)]
    walk += [("Scene", "flat", "anymal")]
    walk = [step for step in walk if step[:2] not in CHECKED_ELSEWHERE]
    for dropdown, value, robot in walk:
        with subtests.test(dropdown=dropdown, value=value):
            switch_draw_push(page, lab, serve, pushes, dropdown, value, robot)


def test_the_shared_page_logged_no_console_error_and_no_traceback(page, serve) -> None:
    """Every switch above: no error in the browser's console ("Tried to update non-existent
    component" was), no traceback in the output of `lab serve` (sim and UI processes; "deque
    mutated during iteration" was)."""
    assert not page.console_errors, page.console_errors[:5]
    output = serve.log.read_text(errors="replace")
    assert "Traceback" not in output and "UI error" not in event_log(page), output[-4000:]
