"""A stopped sim process (SIGSTOP, then SIGCONT): the loop reports the stall when it runs again,
and a stop longer than Zenoh's lease (10 s) is seen by the client as `connected` false until the
process runs again. A real `lab serve` process, a `LabClient` over loopback."""

import os
import signal
import time
from pathlib import Path

from tests.helpers.processes import STARTUP_S, WAIT_S, headless_server, wait_for

STOP_S = 1.0  # the short stop: well inside the lease, the client's link survives it
LEASE_WAIT_S = 60.0  # Zenoh's lease is 10 s; a busy machine adds to it
STOP_ATTEMPTS = 3  # short stops until the client's subscription has seen one


def test_a_stopped_sim_reports_a_stall_and_is_seen_disconnected_while_stopped(
    tmp_path: Path,
) -> None:
    with headless_server(tmp_path) as (running, lab, _):
        pid = running[0].process.pid
        events: list[dict] = []
        lab.subscribe_events(events.append)
        # Stopped again until a stall event arrives: the subscription reaches the server in its
        # own time (a fixed wait was too short on a loaded machine), and a stall before then is
        # published to no one. Each stop is a stall; `skipped` is read before the one seen.
        for attempt in range(STOP_ATTEMPTS):
            skipped = lab.wait_telemetry()["loop"]["skipped"]
            os.kill(pid, signal.SIGSTOP)
            try:
                time.sleep(STOP_S)
            finally:
                os.kill(pid, signal.SIGCONT)
            try:
                wait_for(lambda: any(e["type"] == "stall" for e in events), WAIT_S, "a stall")
                break
            except TimeoutError:
                assert attempt < STOP_ATTEMPTS - 1, f"no stall event after {STOP_ATTEMPTS} stops"
        stall = next(e for e in events if e["type"] == "stall")
        # the loop stood still for about the stop (less the last period), its periods skipped
        assert 0.5 * STOP_S <= stall["seconds"] <= STOP_S + WAIT_S, stall
        assert stall["skipped"] - skipped >= 0.5 * STOP_S * 250, stall  # --rate 250
        assert "stood still" in stall["message"]

        os.kill(pid, signal.SIGSTOP)
        try:  # longer than the lease: the client's link to the stopped process drops
            assert lab.wait_connected(False, timeout=LEASE_WAIT_S)
        finally:
            os.kill(pid, signal.SIGCONT)
        assert lab.wait_connected(True, timeout=STARTUP_S)
        wait_for(lambda: lab.command("info", timeout=2.0)["ok"], WAIT_S, "info answered again")
        ticks = lab.wait_telemetry()["loop"]["ticks"]
        assert lab.wait_telemetry(lambda m: m["loop"]["ticks"] > ticks, timeout=WAIT_S)
