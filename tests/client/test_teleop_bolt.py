"""`lab teleop` drives Bolt over Zenoh: `g` skips the quadruped gaits the server refuses and
starts biped_step, `w` steers it forward, and Bolt walks there (Kim 2016 §V steering)."""

import subprocess
import sys
import time

import pytest

from lab.client import LabClient
from tests.helpers.ports import free_port

STARTUP_TIMEOUT_S = 60.0
WALK_SIM_S = 1.0  # of walking at the commanded 0.1 m/s


def test_teleop_keys_make_bolt_step_and_walk_forward(tmp_path) -> None:
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    cmd = [sys.executable, "-m", "lab.runtime.serve", "--headless", "--robot", "bolt"]
    cmd += ["--port", str(port), "--sched", "other"]
    log = tmp_path / "serve.log"
    with open(log, "wb") as out:
        server = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
    teleop = None
    try:
        lab = _connect(endpoint, server, log)
        with lab:
            teleop = subprocess.Popen(
                [sys.executable, "-m", "lab", "teleop", "--connect", endpoint],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
            )
            teleop.stdin.write(b"g")
            teleop.stdin.flush()
            started = lab.wait_telemetry(lambda m: m["gait"] == "biped_step", timeout=20.0)
            teleop.stdin.write(b"w")  # vx 0.1 m/s, resent by the teleop while held
            teleop.stdin.flush()
            steered = lab.wait_telemetry(lambda m: m["command"]["vx"] > 0.05, timeout=10.0)
            end = lab.wait_telemetry(
                lambda m: m["fell"] or m["t"] > steered["t"] + WALK_SIM_S, timeout=120.0
            )
            teleop.stdin.write(b" x")  # stop, quit
            teleop.stdin.flush()
            output = teleop.communicate(timeout=10.0)[0].decode()
    finally:
        for process in (teleop, server):
            if process is not None and process.poll() is None:
                process.terminate()
                process.wait(timeout=10.0)
    assert 'gait {"name":"trot"} -> ' in output  # refused for Bolt: the next gait of the cycle
    assert 'gait {"name":"biped_step"} -> {\'ok\': True' in output
    assert not end["fell"], log.read_text(errors="replace")
    assert end["stepping"]["steps"] >= 3
    moved = [b - a for a, b in zip(started["com"]["position"], end["com"]["position"], strict=True)]
    assert moved[0] > 0.04  # forward (Bolt faces +x): at least 40 % of the 0.1 m commanded
    assert abs(moved[1]) < 0.05


def _connect(endpoint: str, server: subprocess.Popen, log) -> LabClient:
    end = time.monotonic() + STARTUP_TIMEOUT_S
    while time.monotonic() < end:
        if server.poll() is not None:
            pytest.fail(f"server exited:\n{log.read_text(errors='replace')}")
        try:
            return LabClient(endpoint, connect_timeout=0.5)
        except Exception:
            time.sleep(0.2)
    pytest.fail(f"server did not listen within {STARTUP_TIMEOUT_S} s")
