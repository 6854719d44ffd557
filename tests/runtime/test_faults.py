"""Faults, each with what the user sees and what is kept (docs/reliability.md has the table).

Faults inside the sim (an infeasible problem, a solver exception, NaN in the state, a diverging
simulation, a fall) are injected between two ticks of a real loop serving real Zenoh sessions on
loopback; the user is a `LabClient` that sees the event on `lab/events` and the state in
telemetry. Faults around the sim (a subscriber that never reads, the UI process killed, the sim
process killed, the teleop link cut, the Zenoh router restarted) use real processes.

Loops run at 250 Hz with a 1 ms step (`--rate 250`, SCHED_OTHER) so that they hold on a loaded
2-core machine; waits are generous (tens of seconds) and end as soon as the condition holds.
"""

import math
import os
import signal
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path

import pytest

from lab.runtime.deadman import DEADMAN_RAMP_S, DEADMAN_TIMEOUT_S
from lab.world.session import Session, SessionConfig
from tests.helpers.ports import free_port
from tests.helpers.processes import (
    RATE_HZ,
    STARTUP_S,
    WAIT_S,
    LiveServer,
    Process,
    headless_server,
    live_server,
    processes,
    ready_client,
    serve,
    wait_for,
)


def assert_standing(server: LiveServer, after: float) -> dict:
    """Telemetry shows the robot standing under control, sim time beyond `after`."""
    telemetry = server.telemetry_after(after)
    height = telemetry["base"]["position"][2]
    assert abs(height - server.session.robot.q_standing[2]) < 0.05, telemetry["base"]
    assert not telemetry["fell"]
    return telemetry


def make_infeasible(session: Session) -> Callable[[Session], None]:
    """Contact limits with no solution (a normal force of at least 200 N and at most 100 N);
    returns the fault that restores them."""
    limits = session.controller.config.limits
    sane = (limits.normal_min, limits.normal_max)
    limits.normal_min, limits.normal_max = 200.0, 100.0

    def restore(session: Session) -> None:
        limits.normal_min, limits.normal_max = sane

    return restore


@pytest.mark.parametrize("kernel", ["native", "python"])
def test_an_infeasible_problem_is_a_solver_failure_and_the_solver_takes_over_after(
    kernel: str,
) -> None:
    """Weighted, infeasible contact limits for 50 ticks: every tick ends as a solver failure
    (fallback torques, a solver_failure event), and once the limits are sane the solver takes
    over and the robot stands. (eiquadprog cycled without end on such a problem; the native
    kernel now solves with DAQP, which calls it infeasible: tests/kernel/test_kernel.py.)"""
    session = Session(SessionConfig(robot="anymal"))
    assert session.handle("hierarchy", {"method": "weighted", "kernel": kernel})["ok"]
    for _ in range(100):
        session.tick()
    restore = make_infeasible(session)
    for _ in range(50):
        session.tick()
    assert session.qp_failures == 50
    assert any(e["type"] == "solver_failure" for e in session.pop_events())
    restore(session)
    for _ in range(500):
        session.tick()
    assert session.qp_ok and not session.fell
    assert abs(session.model.q[2] - session.robot.q_standing[2]) < 0.05


def test_a_solver_exception_falls_back_counts_and_carries_on() -> None:
    """The controller raises (as a bug in a solver binding would) for 50 ticks: the user sees a
    solver_failure event naming the error; the loop keeps ticking on fallback torques; the
    controller takes over again and the robot still stands."""
    with live_server() as server:
        controller = server.session.controller
        calls = {"left": 50}

        def raising(method: Callable) -> Callable:
            def call(*args: object) -> object:
                calls["left"] -= 1
                if calls["left"] < 0:
                    return method(*args)
                raise RuntimeError("injected solver exception")

            return call

        def inject(session: object) -> None:
            # A standing tick calls compute (update and solve in one), others solve; the native
            # server tick (native_tick.py) mirrors the limits before its one crossing instead.
            controller.solve = raising(controller.solve)
            controller.compute = raising(controller.compute)
            controller.sync_native_tick = raising(controller.sync_native_tick)

        server.session.inject(inject)
        failure = server.event("solver_failure")
        assert "injected solver exception" in failure["message"]
        wait_for(lambda: calls["left"] < 0, WAIT_S, "the injected exceptions to run out")
        after = server.client.wait_telemetry(
            lambda m: m["status"]["status"] == "ok", timeout=WAIT_S
        )
        assert after["qp"]["failures"] == 50
        assert_standing(server, after["t"] + 0.2)


@pytest.mark.parametrize(
    ("cause", "corrupt"),
    [
        ("position", lambda data: data.qpos.__setitem__(0, math.nan)),
        ("velocity", lambda data: data.qvel.__setitem__(8, 1e12)),
    ],
    ids=["nan_in_the_state", "diverging_simulation"],
)
def test_a_corrupt_state_is_a_divergence_the_robot_stands_again_and_time_goes_on(
    cause: str, corrupt: Callable
) -> None:
    """NaN in the state, or a speed MuJoCo would reset itself for: the user sees sim_diverged
    naming the cause; the robot stands again at the same sim time (the clock never runs back)."""
    with live_server() as server:
        before = server.telemetry_after(0.1)
        server.session.inject(lambda session: corrupt(session.plant.mj_data))
        diverged = server.event("sim_diverged")
        assert cause in diverged["cause"] and diverged["restored"] == "standing"
        assert diverged["t"] >= before["t"]
        after = assert_standing(server, diverged["t"] + 0.3)
        assert after["divergences"] == 1 and not after["paused"]
        assert server.client.command("info")["ok"]


def test_a_fall_turns_the_torques_off_until_reset_and_is_seen() -> None:
    """80 N sideways on Solo12: the user sees a fall event and `fell` in telemetry; after a
    reset the robot stands under control again."""
    with live_server("solo12") as server:
        push = {"body": "base_link", "force": [0.0, 80.0, 0.0], "duration": 1.0}
        assert server.client.command("push", **push)["ok"]
        fall = server.event("fall")
        assert server.telemetry_after(fall["t"])["fell"]
        assert server.client.command("reset")["ok"]
        server.event("reset")
        assert_standing(server, 0.3)


def router(log: Path, port: int) -> Process:
    """A Zenoh router on loopback `port`: `lab router`, a zenoh session in router mode."""
    return Process(log, "-m", "lab", "router", "--port", str(port))


def test_a_subscriber_that_never_reads_does_not_slow_the_loop(tmp_path: Path) -> None:
    """A client process whose telemetry callback blocks forever and another that never drains
    its channel: the loop keeps its schedule and other clients get fresh telemetry."""
    stuck = (
        "import sys, threading, zenoh\n"
        "from lab.zenoh_config import client_config\n"
        "never = threading.Event()\n"
        "session = zenoh.open(client_config(sys.argv[1]))\n"
        "blocked = session.declare_subscriber('lab/**', lambda sample: never.wait())\n"
        "fifo = zenoh.handlers.FifoChannel(1 << 20)\n"
        "undrained = session.declare_subscriber('lab/**', fifo)\n"
        "print('subscribed', flush=True)\n"
        "never.wait()\n"
    )
    with headless_server(tmp_path) as (running, lab, endpoint):
        for i in range(2):
            running.append(Process(tmp_path / f"stuck{i}.log", "-c", stuck, endpoint))
        wait_for(lambda: all("subscribed" in p.output() for p in running[1:]), STARTUP_S, "stuck")
        first = lab.wait_telemetry()
        time.sleep(5.0)
        last = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > first["loop"]["ticks"])
        ticks = last["loop"]["ticks"] + last["loop"]["skipped"]
        ticks -= first["loop"]["ticks"] + first["loop"]["skipped"]
        assert ticks > 0.8 * RATE_HZ * 5.0, last["loop"]  # the schedule held
        assert last["t"] - first["t"] > 0.2 * 5.0 * RATE_HZ * 1e-3  # and the sim ran


def _children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(child) for child in path.read_text().split()] if path.exists() else []


def _page(port: int) -> int | None:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5.0) as response:
            return response.status
    except OSError:
        return None


def test_the_ui_process_killed_is_restarted_and_the_sim_runs_on(tmp_path: Path) -> None:
    """SIGKILL to the UI process: the sim's clock goes on undisturbed (no reset, no pause);
    `lab serve` starts a new UI process which serves the page again for the browser to
    reconnect to."""
    port, ui_port = free_port(), free_port()
    with processes() as running:
        server = serve(tmp_path / "serve.log", port, "--ui-port", str(ui_port))
        running.append(server)
        lab = ready_client(f"tcp/127.0.0.1:{port}", server)
        wait_for(lambda: _page(ui_port) == 200, STARTUP_S, "the UI page")
        (ui,) = _children(server.process.pid)
        before = lab.wait_telemetry()
        os.kill(ui, signal.SIGKILL)
        wait_for(lambda: _children(server.process.pid) not in ([], [ui]), WAIT_S, "a new UI")
        wait_for(lambda: _page(ui_port) == 200, STARTUP_S, "the new UI's page")
        after = lab.wait_telemetry(lambda m: m["t"] > before["t"] + 0.5)
        assert after["loop"]["ticks"] > before["loop"]["ticks"] and not after["paused"]
        assert "restarting it" in server.output()
        assert lab.command("info")["ok"]
        lab.close()


def _running(pid: int) -> bool:
    """Whether process `pid` exists and is not a zombie."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


def test_a_killed_serve_takes_its_ui_process_along(tmp_path: Path) -> None:
    """SIGKILL to `lab serve` (no cleanup runs): its UI process sees its parent gone and stops,
    instead of serving a dead sim's page and holding the port."""
    port, ui_port = free_port(), free_port()
    with processes() as running:
        server = serve(tmp_path / "serve.log", port, "--ui-port", str(ui_port))
        running.append(server)
        wait_for(lambda: _page(ui_port) == 200, STARTUP_S, "the UI page")
        (ui,) = _children(server.process.pid)
        server.kill()
        wait_for(lambda: not _running(ui), WAIT_S, "the orphaned UI process to stop")
        assert _page(ui_port) is None


def test_the_sim_process_killed_is_seen_as_disconnected_and_recovers(tmp_path: Path) -> None:
    """SIGKILL to the sim process: the client says disconnected, commands get "no reply"
    errors instead of hanging; a new sim process on the same port is found again by the same
    client: connected, commands answered, telemetry flowing."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    with processes() as running:
        server = serve(tmp_path / "serve.log", port, "--headless")
        running.append(server)
        lab = ready_client(endpoint, server)
        assert lab.connected
        server.kill()
        assert lab.wait_connected(False, timeout=WAIT_S)
        reply = lab.command("info", timeout=1.0)
        assert not reply["ok"] and "info" in reply["error"]
        again = serve(tmp_path / "serve2.log", port, "--headless")
        running.append(again)
        assert lab.wait_connected(True, timeout=STARTUP_S), again.output()
        wait_for(lambda: lab.command("info", timeout=2.0)["ok"], WAIT_S, "info answered")
        fresh = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > 0, timeout=WAIT_S)
        assert fresh["t"] < 60.0  # the new process's clock, not a stale message
        lab.close()


def test_a_cut_teleop_link_ramps_the_velocity_to_zero(tmp_path: Path) -> None:
    """A teleop process refreshing a walking command is killed: the deadman holds the command
    DEADMAN_TIMEOUT_S after its last refresh, then ramps it to zero over DEADMAN_RAMP_S (wall
    time). The teleop prints the (system-wide monotonic) time each refresh was answered, so the
    hold is measured from the last refresh, whenever the kill lands between two of them."""
    teleop = (
        "import sys, time\n"
        "from lab.client import LabClient\n"
        "lab = LabClient(sys.argv[1])\n"
        "print(lab.command('gait', name='trot'), flush=True)\n"
        "while True:\n"
        "    reply = lab.command('velocity', vx=0.2, vy=0.0, yaw_rate=0.0)\n"
        "    sys.stdout.write(f\"refreshed {time.monotonic()} {reply['ok']}\\n\")  # one write\n"
        "    sys.stdout.flush()\n"
        "    time.sleep(0.1)\n"
    )
    with headless_server(tmp_path) as (running, lab, endpoint):
        link = Process(tmp_path / "teleop.log", "-c", teleop, endpoint)
        running.append(link)
        lab.wait_telemetry(lambda m: m["command"]["vx"] == pytest.approx(0.2), timeout=STARTUP_S)
        # The command can show in telemetry before the teleop has printed its reply: kill it
        # only once it has printed one, so that there is a last refresh to measure from.
        wait_for(lambda: _refresh_times(link.output()), WAIT_S, "the teleop's first refresh")
        link.kill()
        # It ramps down (a value between), not to zero at once: waited for, or a timeout error.
        lab.wait_telemetry(lambda m: 0.0 < m["command"]["vx"] < 0.2, timeout=WAIT_S)
        lab.wait_telemetry(lambda m: m["command"]["vx"] == 0.0, timeout=WAIT_S)
        stopped = time.monotonic()
        last = max(_refresh_times(link.output()))
        # The last applied refresh came at most one reply's latency (0.15 s allowed) before its
        # answer was printed; the command reaches zero DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S later.
        assert stopped - last >= DEADMAN_TIMEOUT_S + DEADMAN_RAMP_S - 0.15
        assert lab.command("info")["ok"]


def _refresh_times(output: str) -> list[float]:
    """The times of the applied refreshes the teleop printed, whole lines only (the kill can
    land in the middle of one)."""
    lines = [line.split() for line in output.splitlines(keepends=True) if line.endswith("\n")]
    return [float(f[1]) for f in lines if len(f) == 3 and f[0] == "refreshed" and f[2] == "True"]


def test_a_restarted_router_reconnects_the_sim_and_its_clients(tmp_path: Path) -> None:
    """Sim process and client reach each other only through a Zenoh router. The router is
    killed: the client says disconnected, the sim runs on; a new router on the same port:
    both reconnect by themselves, commands are answered and telemetry flows again."""
    router_port = free_port()
    router_endpoint = f"tcp/127.0.0.1:{router_port}"
    with processes() as running:
        running.append(router(tmp_path / "router.log", router_port))
        server = serve(
            tmp_path / "serve.log", free_port(), "--headless", "--connect", router_endpoint
        )
        running.append(server)
        lab = ready_client(router_endpoint, server)
        before = lab.wait_telemetry()
        running[0].kill()
        assert lab.wait_connected(False, timeout=WAIT_S)
        running.append(router(tmp_path / "router2.log", router_port))
        assert lab.wait_connected(True, timeout=STARTUP_S), server.output()
        wait_for(lambda: lab.command("info", timeout=2.0)["ok"], WAIT_S, "info answered")
        after = lab.wait_telemetry(lambda m: m["t"] > before["t"], timeout=WAIT_S)
        assert after["loop"]["ticks"] > before["loop"]["ticks"]
        assert server.process.poll() is None
        lab.close()
