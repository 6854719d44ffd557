"""The native kernel gives the same numbers for the same run, from one process to the next.

Two processes, each with its own string hashing (so Python lays out its heap, and with it the
kernel's arrays, differently), run the same sessions: ANYmal trotting under the cascade (its QPs)
and G1 under `nullspace` pushed sideways. Their torques agree to the bit, tick by tick. A build
whose answers depend on where its arrays sit in memory fails this: the AVX2 build tried in round
20, whose vectorised sums started at an address-dependent element (docs/performance.md, "Tried
and not kept"), gave three different τ hashes in three runs of ANYmal trotting.
"""

import os
import subprocess
import sys

import pytest

from lab.controller.native import NOT_BUILT

pytestmark = pytest.mark.skipif(bool(NOT_BUILT), reason=NOT_BUILT or "")

TICKS = 1500
TIMEOUT_S = 600.0  # two sessions' imports and 3000 ticks, on a busy machine

RUN = f"""
import hashlib
import numpy as np
from lab.world.session import Session, SessionConfig

def run(robot, method, commands, push_at):
    session = Session(SessionConfig(robot=robot, method=method, kernel="native"))
    for verb, payload in commands:
        assert session.handle(verb, payload)["ok"], (verb, payload)
    digest = hashlib.sha256()
    for tick in range({TICKS}):
        if tick == push_at:
            push = {{"body": session.robot.base_link, "force": [0.0, 60.0, 0.0], "duration": 0.1}}
            assert session.handle("push", push)["ok"]
        session.tick()
        digest.update(np.asarray(session.tau).tobytes())
    assert session.controller.kernel_ran == "native", robot
    print(robot, method, digest.hexdigest(), session.fell)

trot = [("gait", {{"name": "trot"}}), ("velocity", {{"vx": 0.4, "vy": 0.0, "yaw_rate": 0.2}})]
run("anymal", "cascade", trot, push_at=-1)
run("g1", "nullspace", [], push_at=500)
"""


def run_in_a_process(hash_seed: str) -> list[str]:
    """The lines RUN prints, in a fresh interpreter with PYTHONHASHSEED=hash_seed."""
    env = {**os.environ, "PYTHONHASHSEED": hash_seed}
    done = subprocess.run(
        [sys.executable, "-c", RUN],
        capture_output=True,
        text=True,
        env=env,
        timeout=TIMEOUT_S,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.split("\n")[-3:-1]


def test_the_same_run_in_two_processes_gives_the_same_torques() -> None:
    first, second = run_in_a_process("1"), run_in_a_process("2")
    assert [line.split()[:2] for line in first] == [["anymal", "cascade"], ["g1", "nullspace"]]
    # the runs were whole: neither robot fell (a fall ends what the torques show)
    assert all(line.split()[3] == "False" for line in first), first
    assert first == second
