"""The lab server as a real process, driven over Zenoh on loopback: commands change the running
session, hostile input never stops the loop, signals stop the process promptly.

One server process (ANYmal, headless, `--sched other`: a test server never takes SCHED_FIFO,
which can starve the test process on a small machine) is shared by the tests in file order; the
robot switch comes last. It runs the 1 ms control step on a 250 Hz schedule (`--rate 250`: sim
time at a quarter of wall time) so that the rate assertions hold on a loaded, shared 2-core
machine too (the controller's tick alone is ~0.8-1.3 ms there today);
whether 1 kHz is met is measured by benchmarks/bench_server.py, not by a timed test.
"""

import itertools
import json
import math
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from lab.client import LabClient
from lab.protocol import MAX_PAYLOAD_BYTES
from lab.runtime.loop import MAX_BEHIND_S
from lab.runtime.transport import encode
from tests.helpers.ports import free_port
from tests.helpers.processes import wait_for

STARTUP_TIMEOUT_S = 60.0
SHUTDOWN_TIMEOUT_S = 10.0  # a hung shutdown never ends; a loaded 2-core machine took > 2 s
RATE_HZ = 250.0
TIMESTEP_S = 1e-3
SLOWDOWN = 1.0 / (RATE_HZ * TIMESTEP_S)  # wall seconds per simulated second


class Server:
    def __init__(self, log: Path, *args: str) -> None:
        self.port = free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.log = log
        cmd = [sys.executable, "-m", "lab.runtime.serve", "--headless", "--port", str(self.port)]
        cmd += ["--rate", str(RATE_HZ), "--sched", "other"]
        with open(log, "wb") as out:
            self.process = subprocess.Popen([*cmd, *args], stdout=out, stderr=subprocess.STDOUT)

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def client(self) -> LabClient:
        end = time.monotonic() + STARTUP_TIMEOUT_S
        while time.monotonic() < end:
            assert self.process.poll() is None, f"server exited:\n{self.output()}"
            try:
                return LabClient(self.endpoint, connect_timeout=0.5)
            except Exception:
                time.sleep(0.2)
        raise TimeoutError(f"server did not listen within {STARTUP_TIMEOUT_S} s:\n{self.output()}")

    def stop(self, sig: int) -> float:
        """Send `sig`, return seconds until exit (kills and fails after the timeout)."""
        start = time.monotonic()
        self.process.send_signal(sig)
        try:
            code = self.process.wait(SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
            pytest.fail(f"server ignored signal {sig} for {SHUTDOWN_TIMEOUT_S} s:\n{self.output()}")
        assert code == 0, self.output()
        return time.monotonic() - start


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    srv = Server(tmp_path_factory.mktemp("serve") / "log.txt", "--robot", "anymal")
    yield srv
    if srv.process.poll() is None:
        srv.process.kill()
        srv.process.wait()


@pytest.fixture(scope="module")
def lab(server: Server) -> Iterator[LabClient]:
    client = server.client()
    end = time.monotonic() + STARTUP_TIMEOUT_S
    while not client.command("info", timeout=1.0).get("ok"):
        assert time.monotonic() < end, server.output()
    client.wait_telemetry(timeout=5.0)
    yield client
    client.close()


@pytest.fixture(scope="module")
def info(lab: LabClient) -> dict:
    return lab.command("info")


def collect(endpoint: str, seconds: float) -> dict[str, list[dict]]:
    """Telemetry and state received by a fresh client for `seconds` from when both flow (a
    subscriber just declared receives nothing until the server knows it: on a loaded machine
    that took longer than a fixed wait)."""
    received: dict[str, list[dict]] = {"telemetry": [], "state": []}
    with LabClient(endpoint) as listener:
        listener.subscribe_telemetry(received["telemetry"].append)
        listener.subscribe_state(received["state"].append)
        wait_for(
            lambda: received["telemetry"] and received["state"],
            STARTUP_TIMEOUT_S,
            "telemetry and state at a new client",
        )
        time.sleep(seconds)
    return received


def assert_on_schedule(lab: LabClient, seconds: float) -> None:
    """Over `seconds` of wall time the schedule advanced at RATE_HZ (ticks run plus periods
    explicitly skipped after a stall: the loop does not drift) and the loop kept ticking.

    The wall time is the loop's own clock between the two messages (`loop.clock_s`), so a test
    process that reads telemetry late on a loaded machine does not count. Allowed error: each end
    may be up to MAX_BEHIND_S behind (not yet run nor skipped) plus a period (a loop that slept a
    period after its work would drift by work / period: 10-30 % of the window here). How many
    periods ran is the benchmark's business: at SCHED_OTHER, load 15, 2 cores, it was 40 %."""
    first = lab.wait_telemetry()
    time.sleep(seconds)
    last = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > first["loop"]["ticks"])
    wall = last["loop"]["clock_s"] - first["loop"]["clock_s"]
    assert wall > 0.5 * seconds, (first["loop"], last["loop"])
    ticks = last["loop"]["ticks"] - first["loop"]["ticks"]
    skipped = last["loop"]["skipped"] - first["loop"]["skipped"]
    slack = RATE_HZ * 2 * (MAX_BEHIND_S + 1.0 / RATE_HZ)
    assert abs(ticks + skipped - RATE_HZ * wall) <= slack, (wall, last["loop"])
    assert ticks / wall > 0.2 * RATE_HZ, last["loop"]  # alive, not stuck


def base_body(info: dict) -> str:
    return "base" if "base" in info["bodies"] else info["bodies"][0]


def test_info_answers_with_choices_and_current_state(info: dict) -> None:
    assert info["ok"] is True
    assert {"anymal", "solo12"} <= set(info["robots"])
    assert "flat" in info["scenes"]
    assert {"cascade", "weighted"} <= set(info["methods"])
    assert {"daqp", "clarabel"} <= set(info["solvers"])
    assert info["robot"] == "anymal"
    stack = info["stack"]
    assert stack and all(isinstance(level, list) and level for level in stack)
    assert {name for level in stack for name in level} <= set(info["known"])
    assert {task["name"] for task in info["tasks"]} <= set(info["known"])
    assert info["limits"]["vx"] == 2.0
    assert info["loop"]["ticks"] > 0


def test_telemetry_and_state_stream_at_rate_with_the_loop_on_schedule(
    lab: LabClient, server: Server, info: dict
) -> None:
    received = collect(server.endpoint, 1.5)
    telemetry, states = received["telemetry"], received["state"]
    first, last = telemetry[0], telemetry[-1]
    # Rates by the loop's own counts (a loop that a busy machine runs late publishes fewer
    # messages per wall second, which is the benchmark's business): telemetry at 100 Hz of loop
    # ticks (every 2nd at 250 Hz), each one delivered.
    gaps = {b["loop"]["ticks"] - a["loop"]["ticks"] for a, b in itertools.pairwise(telemetry)}
    assert gaps == {RATE_HZ // 100}, f"ticks between telemetry messages: {sorted(gaps)}"
    state_hz = (len(states) - 1) / (states[-1]["t"] - states[0]["t"])  # per sim second
    assert state_hz >= 54, f"lab/state at {state_hz:.0f} Hz of sim time, well below 60 Hz"
    ticks = last["loop"]["ticks"] - first["loop"]["ticks"]
    assert last["t"] - first["t"] == pytest.approx(ticks * TIMESTEP_S, rel=1e-6)
    loop = last["loop"]
    assert loop["realtime"] and loop["rate_hz"] == RATE_HZ
    assert 0.0 < loop["on_time_fraction"] <= 1.0  # its level is the benchmark's business
    assert_on_schedule(lab, 2.0)
    state = states[-1]
    assert state["robot"] == "anymal"
    assert len(state["joints"]["names"]) == len(state["joints"]["positions"]) == 12
    assert len(state["base"]["quaternion"]) == 4
    assert math.isclose(sum(c * c for c in state["base"]["quaternion"]), 1.0, rel_tol=1e-6)
    # every link and contact frame placed, for the UI to draw with (the base link is the base)
    frames = dict(zip(state["frames"]["names"], state["frames"]["positions"], strict=True))
    assert len(state["frames"]["quaternions"]) == len(frames)
    assert frames[info["base"]] == pytest.approx(state["base"]["position"], abs=1e-12)
    assert {f"{leg}_FOOT_centre" for leg in ("LF", "RF", "LH", "RH")} <= set(frames)
    for key in ("base", "com", "momentum", "contacts", "cop", "tasks", "stack", "qp"):
        assert key in last, key
    assert len(last["contacts"]) == 4
    weight = sum(c["measured_force"][2] for c in last["contacts"])
    assert weight > 100.0  # standing: the feet carry the robot


def test_push_moves_the_base_in_the_pushed_direction(lab: LabClient, info: dict) -> None:
    before = lab.wait_telemetry()
    assert abs(before["base"]["linear_velocity"][1]) < 0.05
    reply = lab.command("push", body=base_body(info), force=[0.0, 200.0, 0.0], duration=0.2)
    assert reply["ok"], reply
    pushed = lab.wait_telemetry(lambda m: m["base"]["linear_velocity"][1] > 0.1, timeout=SLOWDOWN)
    vx, vy, _ = pushed["base"]["linear_velocity"]
    assert vy > 2 * abs(vx)
    assert pushed["pushes"] or pushed["t"] - before["t"] > 0.2
    lab.wait_telemetry(lambda m: abs(m["base"]["linear_velocity"][1]) < 0.05, timeout=3 * SLOWDOWN)
    assert not lab.latest_telemetry()["fell"]


def test_velocity_command_expires_through_the_deadman(lab: LabClient) -> None:
    assert lab.command("velocity", vx=0.3)["ok"]
    sent = time.monotonic()
    lab.wait_telemetry(lambda m: m["command"]["vx"] == pytest.approx(0.3), timeout=0.3)
    lab.wait_telemetry(lambda m: 0.0 < m["command"]["vx"] < 0.3, timeout=1.0)
    assert time.monotonic() - sent > 0.45  # held for the 0.5 s timeout first
    lab.wait_telemetry(lambda m: m["command"]["vx"] == 0.0, timeout=1.0)
    assert time.monotonic() - sent < 1.3  # then ramped to zero over 0.5 s


def test_stack_reorder_is_acknowledged_and_appears_in_telemetry(lab: LabClient) -> None:
    original = lab.command("info")["stack"]
    reordered = [original[0], *reversed(original[1:])] if len(original) > 2 else original[::-1]
    assert reordered != original
    reply = lab.command("stack", levels=reordered)
    assert reply["ok"], reply
    lab.wait_telemetry(lambda m: m["stack"] == reordered, timeout=0.5)
    assert lab.command("info")["stack"] == reordered
    assert lab.command("stack", levels=original)["ok"]
    lab.wait_telemetry(lambda m: m["stack"] == original, timeout=0.5)


def test_hierarchy_switch_takes_effect(lab: LabClient) -> None:
    current = lab.command("info")["hierarchy"]
    other = "weighted" if current["method"] != "weighted" else "cascade"
    reply = lab.command("hierarchy", method=other)
    assert reply["ok"], reply
    message = lab.wait_telemetry(lambda m: m["hierarchy"]["method"] == other, timeout=0.5)
    assert message["status"]["status"] == "ok"
    assert lab.command("hierarchy", method=current["method"], solver=current["solver"])["ok"]
    lab.wait_telemetry(lambda m: m["hierarchy"]["method"] == current["method"], timeout=0.5)


def test_pause_stops_sim_time_but_not_the_loop(lab: LabClient) -> None:
    assert lab.command("pause")["ok"]
    a = lab.wait_telemetry(lambda m: m["paused"], timeout=0.5)
    time.sleep(0.2)
    b = lab.wait_telemetry()
    assert b["t"] == a["t"]
    assert b["loop"]["ticks"] > a["loop"]["ticks"]
    assert lab.command("resume")["ok"]
    c = lab.wait_telemetry(lambda m: not m["paused"], timeout=0.5)
    lab.wait_telemetry(lambda m: m["t"] > c["t"] + 0.05, timeout=SLOWDOWN)


def hostile_requests(body: str, task: str) -> list[tuple[str, bytes]]:
    """Several hundred (verb, raw payload) pairs, every one of which must be rejected."""
    numbers = ["true", "false", "null", '"1"', "[]", "{}", "NaN", "Infinity", "-Infinity", "1e400"]
    huge = ["1e6", "-1e6", "123456789012345678901234567890"]
    out: list[tuple[str, object]] = []
    for field in ("vx", "vy", "yaw_rate"):
        out += [("velocity", f'{{"{field}": {n}}}') for n in numbers + huge]
    push = {"body": body, "force": [0, 10, 0], "duration": 0.1}
    for field in ("body", "force", "duration", "point"):
        for n in [*numbers, *huge, "[1, 2]", "[1, 2, 3, 4]", '["a", "b", "c"]', '""']:
            out.append(("push", json.dumps(push)[:-1] + f', "{field}": {n}}}'))
    out += [("push", json.dumps({**push, "force": [3000, 0, 0]}))]
    out += [("push", json.dumps({**push, "body": "no_such_link"}))]
    out += [("push", json.dumps({**push, "duration": 0}))]
    for verb in ("robot", "scene", "gait", "hierarchy"):
        field = "method" if verb == "hierarchy" else "name"
        for n in [*numbers, '"no_such_thing"', json.dumps("x" * 10_000), '"../../etc"']:
            out.append((verb, f'{{"{field}": {n}}}'))
    out += [("hierarchy", json.dumps({"method": "cascade", "solver": "osqp_nope"}))]
    for n in [*numbers, "[[]]", '[["no_such_task"]]', '[["a", "a"]]', "[" * 50 + "]" * 50]:
        out.append(("stack", f'{{"levels": {n}}}'))
    for n in [*numbers, '"no_such_preset"', '"../stacks/raiola_s3"', json.dumps("x" * 10_000)]:
        out.append(("stack", f'{{"preset": {n}}}'))
    for field in ("kp", "kd", "weight"):
        for n in [*numbers, "-1", "1e9"]:
            out.append(("gains", f'{{"task": "{task}", "{field}": {n}}}'))
    out += [("gains", json.dumps({"task": "no_such_task", "kp": 1.0}))]
    out += [("gains", json.dumps({"task": task}))]
    for verb in ("info", "reset", "pause", "resume", "velocity", "push", "stack"):
        out += [
            (verb, '{"unknown_field": 1}'),
            (verb, "[1, 2, 3]"),
            (verb, '"a string"'),
            (verb, "42"),
            (verb, "null"),
            (verb, "{not json"),
            (verb, '{"a": '),
            (verb, b"\xff\xfe\x00garbage"),
            (verb, "[" * 100_000),
            (verb, "{" + '"a":{' * 5000 + "}" * 5001),
            (verb, '{"vx": "' + "x" * (MAX_PAYLOAD_BYTES + 10) + '"}'),
        ]
    unknown = ("jump", "selfdestruct", "INFO", "push/extra", "a" * 200, "velocity%20", "stand")
    for verb in (*unknown, "teleport", "cmd", "-1", "robot/anymal"):
        out.append((verb, "{}"))
    return [(v, p if isinstance(p, bytes) else p.encode()) for v, p in out]


def test_hostile_payloads_are_each_rejected_and_the_loop_keeps_its_rate(
    lab: LabClient, info: dict
) -> None:
    task = info["tasks"][0]["name"]
    requests = hostile_requests(base_body(info), task)
    assert len(requests) >= 300
    before = lab.command("info")
    start = lab.wait_telemetry()
    started = time.monotonic()
    failures = []
    for verb, payload in requests:
        reply = lab.request(verb, payload, timeout=2.0)
        unanswered = "no reply" in reply.get("error", "") or "unanswered" in reply.get("error", "")
        if reply.get("ok") is not False or not reply.get("error") or unanswered:
            failures.append((verb, payload[:80], reply))
    elapsed = time.monotonic() - started
    assert not failures, failures[:5]
    end = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > start["loop"]["ticks"])
    # the loop kept ticking through the flood (how close to 1 kHz depends on the controller's
    # tick time and the machine's load: the benchmark measures it) and is back at rate after it
    ticks = end["loop"]["ticks"] - start["loop"]["ticks"]
    assert ticks / (elapsed * RATE_HZ) > 0.5
    assert_on_schedule(lab, 2.0)
    assert not lab.wait_telemetry()["fell"]
    after = lab.command("info")
    for key in ("robot", "scene", "stack", "tasks", "hierarchy", "paused"):
        assert after[key] == before[key], key


def test_rejections_are_reported_on_events(lab: LabClient, server: Server) -> None:
    events: list[dict] = []
    with LabClient(server.endpoint) as listener:
        listener.subscribe_events(events.append)
        # Rejected again until the listener has an event: its subscription reaches the server
        # in its own time (the commands come from another client), and events of one kind are
        # folded to one per second, so a rejection before then is never seen.
        end = time.monotonic() + STARTUP_TIMEOUT_S
        while not any(e["type"] == "rejected_command" for e in events):
            assert time.monotonic() < end, f"no rejected_command event; received {events}"
            assert not lab.command("velocity", vx=99.0)["ok"]
            time.sleep(0.3)
    rejected = [e for e in events if e["type"] == "rejected_command"]
    assert rejected and rejected[-1]["verb"] == "velocity" and "vx" in rejected[-1]["error"]


def test_teleop_keys_reach_the_server(lab: LabClient, server: Server) -> None:
    teleop = subprocess.Popen(
        [sys.executable, "-m", "lab", "teleop", "--connect", server.endpoint],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        teleop.stdin.write(b"ww")  # forward twice: vx 0.2, resent while held
        teleop.stdin.flush()
        lab.wait_telemetry(lambda m: m["command"]["vx"] == pytest.approx(0.2), timeout=10.0)
        time.sleep(0.8)  # longer than the deadman: the teleop's refreshes keep it alive
        assert lab.wait_telemetry()["command"]["vx"] == pytest.approx(0.2)
        teleop.stdin.write(b" x")  # stop, quit
        teleop.stdin.flush()
        output = teleop.communicate(timeout=5.0)[0].decode()
    finally:
        if teleop.poll() is None:
            teleop.kill()
            teleop.wait()
    assert teleop.returncode == 0, output
    assert """velocity {"vx":0.2,"vy":0.0,"yaw_rate":0.0} -> {'ok': True}""" in output
    lab.wait_telemetry(lambda m: m["command"]["vx"] == 0.0, timeout=1.0)


def test_the_floor_is_measured_at_start_up_and_again_on_command(lab: LabClient, info: dict) -> None:
    """`lab serve` measures the machine's floor (the loop, empty) before the sim starts (issue
    31); the `floor` command measures it again while the session stands still, and `info`
    carries the new one from then on."""
    first = info["loop"]["floor"]
    assert first is not None and first["seconds"] == 2.0 and first["ticks"] >= 500, first
    assert 0.0 < first["on_time_fraction"] <= 1.0
    before = lab.command("info")["loop"]
    reply = lab.command("floor", seconds=1.0)
    after = lab.command("info")["loop"]
    assert reply["ok"], reply
    floor = reply["floor"]
    assert floor["seconds"] == 1.0 and floor["clock_s"] > first["clock_s"]
    assert after["floor"] == floor
    wall = after["clock_s"] - before["clock_s"]
    served = after["ticks"] + after["skipped"] - before["ticks"] - before["skipped"]
    # Had the session ticked during the floor, `served` would be a whole second's ticks above
    # the bound; half of it is slack for the loop's catching up and the replies' timing on a
    # busy machine (2 * MAX_BEHIND_S alone failed once at load 16).
    slack = max(RATE_HZ * 2 * (MAX_BEHIND_S + 1.0 / RATE_HZ), 0.5 * RATE_HZ)
    assert served <= RATE_HZ * (wall - 1.0) + slack, (wall, served)  # none during the floor


def test_robot_switch_brings_up_the_new_robot(lab: LabClient, server: Server) -> None:
    reply = lab.command("robot", name="solo12")
    assert reply["ok"], reply
    message = lab.wait_telemetry(lambda m: m["robot"] == "solo12", timeout=2.0)
    assert len(message["contacts"]) == 4
    time.sleep(0.5 * SLOWDOWN)
    settled = lab.wait_telemetry()
    assert not settled["fell"]
    assert 0.1 < settled["base"]["position"][2] < 0.4  # Solo12 stands ~0.25 m high
    assert lab.command("info")["robot"] == "solo12"
    assert_on_schedule(lab, 2.0)


def test_sigint_stops_the_server(server: Server, lab: LabClient) -> None:
    assert server.stop(signal.SIGINT) < SHUTDOWN_TIMEOUT_S


def test_sigterm_stops_a_fresh_server(tmp_path: Path) -> None:
    srv = Server(tmp_path / "log.txt", "--robot", "solo12")
    try:
        with srv.client() as client:
            end = time.monotonic() + STARTUP_TIMEOUT_S
            while not client.command("info", timeout=1.0).get("ok"):
                assert time.monotonic() < end, srv.output()
            client.wait_telemetry(timeout=5.0)
        assert srv.stop(signal.SIGTERM) < SHUTDOWN_TIMEOUT_S
    finally:
        if srv.process.poll() is None:
            srv.process.kill()
            srv.process.wait()


def test_messages_are_json_with_numpy_numbers_and_null_for_non_finite() -> None:
    message = {"t": np.float64(0.5), "n": np.int64(3), "v": np.arange(2.0), "cop": math.nan}
    assert json.loads(encode(message)) == {"t": 0.5, "n": 3, "v": [0.0, 1.0], "cop": None}
    with pytest.raises(TypeError, match="object"):
        encode({"bad": object()})
