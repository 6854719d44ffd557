"""`lab serve --record` writes a live session to MCAP; `lab replay --serve` plays a recording
over the protocol like a live session, steered by pause, resume, speed and seek."""

import signal
import time
from pathlib import Path

import numpy as np
import pytest

from lab.recording.replay import read_recording, replay
from lab.recording.replay_serve import Player, ReplayServer
from tests.helpers.ports import free_port
from tests.helpers.processes import RATE_HZ, WAIT_S, Process, ready_client, serve

STOP_S = 10.0


@pytest.fixture(scope="module")
def live_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A live ANYmal session: pushed, a bad command, reset (its clock restarts), then on."""
    tmp = tmp_path_factory.mktemp("live")
    port, path = free_port(), tmp / "live.mcap"
    server = serve(tmp / "serve.log", port, "--headless", "--record", str(path))
    try:
        with ready_client(f"tcp/127.0.0.1:{port}", server) as lab:
            lab.wait_telemetry(lambda m: m["t"] > 0.4, timeout=WAIT_S)
            assert lab.command("push", body="base", force=[0, 60, 0], duration=0.1)["ok"]
            assert not lab.command("gains", task="no_such_task", kp=1.0)["ok"]
            lab.wait_telemetry(lambda m: m["t"] > 0.8, timeout=WAIT_S)
            assert lab.command("reset")["ok"]
            lab.wait_telemetry(lambda m: 0.3 < m["t"] < 0.8, timeout=WAIT_S)
        server.process.send_signal(signal.SIGINT)
        assert server.process.wait(STOP_S) == 0, server.output()
    finally:
        server.kill()
    return path


def test_a_live_session_is_recorded_with_replies_events_and_a_timeline_that_goes_on(
    live_recording: Path,
) -> None:
    messages = read_recording(live_recording).messages
    commands = [m.data for m in messages if m.kind == "commands"]
    verbs = [(c["verb"], c["reply"]["ok"]) for c in commands]
    assert ("push", True) in verbs and ("gains", False) in verbs and ("reset", True) in verbs
    assert "reset" in [m.data["type"] for m in messages if m.kind == "events"]
    telemetry = [m for m in messages if m.kind == "telemetry"]
    assert len(telemetry) > 100 and all(len(m.data["tau"]) == 12 for m in telemetry)
    session_times = np.array([m.data["t"] for m in telemetry])
    assert np.any(np.diff(session_times) < -0.5)  # the reset restarted the session clock...
    log_times = np.array([m.t for m in messages])
    assert np.all(np.diff(log_times) >= 0.0)  # ...not the recording's timeline
    assert log_times[-1] == pytest.approx(session_times.max() + session_times[-1], abs=0.05)


def test_a_player_plays_at_its_speed_pauses_and_seeks(live_recording: Path) -> None:
    messages = read_recording(live_recording).messages
    player = Player([m for m in messages if m.kind != "commands"])
    first = player.advance(0.1)
    assert first and max(m.t for m in first) <= 0.1
    player.speed = 4.0
    assert max(m.t for m in player.advance(0.1)) == pytest.approx(0.5, abs=0.02)
    player.paused = True
    assert player.advance(1.0) == [] and player.position == pytest.approx(0.5)
    shown = player.seek(0.25)
    assert {m.kind for m in shown} == {"telemetry", "state"} and max(m.t for m in shown) <= 0.25
    player.paused = False
    assert min(m.t for m in player.advance(0.01)) > 0.25
    player.seek(1e9)
    assert player.position == player.duration and player.advance(1.0) == [] and player.ended


def test_playback_commands_are_checked_and_other_verbs_are_refused(live_recording: Path) -> None:
    # handle() publishes nothing...
    server = ReplayServer(read_recording(live_recording), transport=None)
    info = server.handle("info", {})
    assert info["ok"] and info["recorded"]["robot"] == "anymal" and info["replay"]["t"] == 0.0
    assert server.handle("speed", {"factor": 2.5})["replay"]["speed"] == 2.5
    for verb, payload, words in (  # parse_replay_command's words (tests/protocol)
        ("speed", {"factor": 0}, "field 'factor' = 0 is out of range (0, 100]"),
        ("speed", {"factor": float("nan")}, "field 'factor' must be finite"),
        ("speed", {"rate": 2}, "unknown field(s) 'rate' (expected factor)"),
        ("seek", {"t": "soon"}, "field 't' must be a number"),
        ("pause", {"now": True}, "unknown field(s) 'now'"),
        ("push", {"body": "base"}, "read-only"),
    ):
        reply = server.handle(verb, payload)
        assert not reply["ok"] and verb in reply["error"] and words in reply["error"], reply
    assert server.player.speed == 2.5  # refused commands changed nothing
    assert server.handle("pause", {})["replay"]["paused"] is True


def test_a_recording_is_served_like_a_live_session(live_recording: Path, tmp_path: Path) -> None:
    port = free_port()
    replay = Process(
        tmp_path / "replay.log",
        "-m",
        "lab",
        "replay",
        str(live_recording),
        "--serve",
        "--port",
        str(port),
        "--speed",
        "0.5",
    )
    try:
        with ready_client(f"tcp/127.0.0.1:{port}", replay) as lab:
            info = lab.command("info")
            assert info["recorded"]["robot"] == "anymal" and info["replay"]["duration"] > 1.0
            # the recorded session's own info, so the page draws the recorded robot's panels
            assert info["robot"] == "anymal" and "contact" in info["known"]
            assert lab.command("pause")["ok"]
            time.sleep(0.3)
            lab.latest_telemetry()
            lab.command("seek", t=0.5)
            shown = lab.wait_telemetry(timeout=WAIT_S)  # seek shows the telemetry at 0.5 s
            assert 0.45 <= shown["t"] <= 0.5 and shown["robot"] == "anymal"
            assert shown["replay"]["t"] == 0.5 and shown["replay"]["paused"]  # the timeline
            assert not lab.command("reset")["ok"]
            ended = []  # subscribed before the replay resumes: the server has the subscription
            # before the commands below (one link, in order), so the end cannot come first
            lab.subscribe_events(lambda e: ended.append(e) if e["type"] == "replay_ended" else None)
            assert lab.command("resume")["ok"] and lab.command("speed", factor=4.0)["ok"]
            deadline = time.monotonic() + WAIT_S
            while not ended and time.monotonic() < deadline:
                time.sleep(0.1)
            assert ended and lab.command("info")["replay"]["ended"]
        replay.process.send_signal(signal.SIGINT)
        assert replay.process.wait(STOP_S) == 0, replay.output()
    finally:
        replay.kill()


def test_the_record_command_starts_and_stops_a_recording_of_the_live_session(
    tmp_path: Path,
) -> None:
    """What the page's Record button sends: `lab serve` writes a file in --record-dir whose
    timeline starts at 0 although the session had run; telemetry says a recording runs; a
    second start or a stop with nothing running is refused and changes nothing."""
    port, folder = free_port(), tmp_path / "recordings"
    server = serve(tmp_path / "serve.log", port, "--headless", "--record-dir", str(folder))
    try:
        with ready_client(f"tcp/127.0.0.1:{port}", server) as lab:
            stop = lab.command("record", action="stop")
            assert not stop["ok"] and "nothing is being recorded" in stop["error"]
            assert not lab.command("record", action="rewind")["ok"]
            lab.wait_telemetry(lambda m: m["t"] > 0.5, timeout=WAIT_S)
            assert lab.wait_telemetry(timeout=WAIT_S)["recording"] is None
            started = lab.command("record", action="start")
            assert started["ok"], started
            path = Path(started["recording"]["file"])
            assert path.parent == folder and path.name.startswith("lab-anymal-")
            again = lab.command("record", action="start")
            assert not again["ok"] and "already recording" in again["error"]
            assert lab.command("push", body="base", force=[0, 40, 0], duration=0.1)["ok"]
            running = lab.wait_telemetry(
                lambda m: (m["recording"] or {}).get("seconds", 0) > 0.4, timeout=WAIT_S
            )
            assert running["recording"]["file"] == str(path)
            done = lab.command("record", action="stop")
            assert done["ok"] and done["recorded"]["bytes"] == path.stat().st_size > 0
            lab.wait_telemetry(lambda m: m["recording"] is None, timeout=WAIT_S)
    finally:
        server.kill()
    messages = read_recording(path).messages
    times = [m.t for m in messages]
    assert times[0] < 0.05 and times[-1] == pytest.approx(done["recorded"]["seconds"], abs=0.05)
    verbs = [m.data["verb"] for m in messages if m.kind == "commands"]
    assert "push" in verbs and "record" not in verbs
    telemetry = [m.data for m in messages if m.kind == "telemetry"]
    assert telemetry[0]["t"] > 0.5  # the session had run before the recording began


def test_a_recording_killed_mid_run_replays_what_was_flushed(tmp_path: Path) -> None:
    """SIGKILL of `lab serve --record`: the file has no summary, yet its chunks (flushed every
    FLUSH_S of wall time) replay, through a session and served, and say what was lost."""
    port, path = free_port(), tmp_path / "killed.mcap"
    server = serve(tmp_path / "serve.log", port, "--headless", "--record", str(path))
    try:
        with ready_client(f"tcp/127.0.0.1:{port}", server) as lab:
            assert lab.command("push", body="base", force=[0, 40, 0], duration=0.1)["ok"]
            seen = lab.wait_telemetry(lambda m: m["t"] > 1.0, timeout=WAIT_S)["t"]
            server.process.send_signal(signal.SIGKILL)
            server.process.wait(STOP_S)
    finally:
        server.kill()
    recording = read_recording(path)
    assert recording.cut_short is not None and "killed mid-write?" in recording.cut_short
    # a flush every FLUSH_S of wall time: at most ~1 s of wall time is lost, RATE_HZ ticks of
    # 1 ms a second, and what came after the last telemetry this client saw is not counted
    assert seen - recording.seconds <= 1.0 * RATE_HZ * 1e-3, (recording.seconds, seen)
    assert "push" in [m.data["verb"] for m in recording.messages if m.kind == "commands"]
    check = replay(path)
    assert check.cut_short == recording.cut_short and check.compared > 0
    assert check.max_torque_error <= 1e-9 and check.commands == 2  # info, push
    assert check.replies_differ == 1  # the live loop's statistics in info's, not a session's
    served = ReplayServer(recording, transport=None).handle("info", {})
    assert served["replay"]["cut_short"] == recording.cut_short
    assert served["replay"]["duration"] == pytest.approx(recording.seconds, abs=0.05)
