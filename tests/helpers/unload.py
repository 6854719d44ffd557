"""G1's active-set searches while its leaving sole unloads (`lab bench --gaits single`'s set-up
on the Python kernel: `nullspace` on one sole, Herzog's push at tick 1000), recorded once per
process: the ticks where every search tries to release the pinned rows of that sole."""

import functools

import numpy as np

from lab.controller.hierarchy import nullspace
from lab.controller.hierarchy.problem import Level
from lab.experiments.bench import GAITS, HERZOG_PUSH
from lab.world.session import Session, SessionConfig

PUSH_TICK = 1000  # lab bench's push (release_sensitivity.py's PUSH_TICK)
UNLOAD_TICKS = 150  # the tests' ticks from the push: ~700 release trials

Search = tuple[list[Level], int, list[np.ndarray] | None, np.ndarray | None]


@functools.cache
def g1_unload_searches(ticks: int) -> tuple[Search, ...]:
    """(levels, n, start, point) of each search of the first `ticks` ticks from the push."""
    session = Session(SessionConfig(robot="g1", method="nullspace", kernel="python"))
    for verb, payload in GAITS["single"].commands:
        assert session.handle(verb, payload)["ok"], verb
    assert session.handle("hierarchy", {"method": "nullspace", "kernel": "python"})["ok"]
    for _ in range(PUSH_TICK):
        session.tick()
    force, duration = HERZOG_PUSH
    push = {"body": session.robot.base_link, "force": [0.0, force, 0.0], "duration": duration}
    assert session.handle("push", push)["ok"]
    searches: list[Search] = []
    search = nullspace.active_set_least_squares

    def recorded(levels, n, cap=None, start=None, point=None):
        rows = None if start is None else [np.array(on) for on in start]
        searches.append((list(levels), n, rows, None if point is None else point.copy()))
        return search(levels, n, cap=cap, start=start, point=point)

    nullspace.active_set_least_squares = recorded
    try:
        for _ in range(ticks):
            session.tick()
    finally:
        nullspace.active_set_least_squares = search
    assert not session.fell
    return tuple(searches)
