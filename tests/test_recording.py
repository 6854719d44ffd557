"""Recording a headless run to MCAP and replaying it through a new session."""

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from lab.server.recording import SCHEMAS, TOPICS, read_recording, replay
from lab.server.scenario import Event, load_scenario, run_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
REPLAY_TOL = 1e-9  # N m: the tick is deterministic on one machine


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """ANYmal pushed sideways, a gain changed and a bad command sent, recorded for 1.2 s."""
    scenario = load_scenario(SCENARIOS / "anymal_push_lateral.toml")
    scenario.events.extend(
        [
            Event(0.3, "gains", {"task": "posture", "kp": 80.0}),
            Event(0.4, "gains", {"task": "no_such_task", "kp": 1.0}),
        ]
    )
    scenario.events.sort(key=lambda event: event.t)
    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    report = run_scenario(scenario, 1.2, record=path)
    assert not report["fell"]
    return path


def test_a_replay_through_the_session_gives_the_same_torques(recording: Path) -> None:
    check = replay(recording)
    assert check.ticks == 1200
    assert check.commands == 3  # the gain, the rejected gain, the push
    assert check.compared == 120  # telemetry at 100 Hz
    assert check.max_torque_error <= REPLAY_TOL
    assert check.replies_differ == 0


def test_the_recording_is_plain_mcap_with_json_schemas(recording: Path) -> None:
    """What Foxglove and PlotJuggler need: JSON messages on channels with a JSON schema, the
    schema's required fields in every message."""
    counts = dict.fromkeys(TOPICS.values(), 0)
    with recording.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            assert channel.message_encoding == "json"
            assert schema.encoding == "jsonschema"
            kind = next(k for k, topic in TOPICS.items() if topic == channel.topic)
            assert json.loads(schema.data) == SCHEMAS[kind]
            data = json.loads(message.data)
            assert set(SCHEMAS[kind]["required"]) <= set(data)
            assert message.log_time == round(data["t"] * 1e9)
            counts[channel.topic] += 1
    assert counts["lab/telemetry"] == 120 and counts["lab/state"] == 1200 // 16
    assert counts["lab/commands"] == 3 and counts["lab/events"] >= 1


def test_commands_keep_their_replies_and_events_say_what_was_rejected(recording: Path) -> None:
    _, messages = read_recording(recording)
    messages = list(messages)
    commands = [m.data for m in messages if m.kind == "commands"]
    assert [c["verb"] for c in commands] == ["gains", "gains", "push"]
    assert [c["reply"]["ok"] for c in commands] == [True, False, True]
    assert "no_such_task" in commands[1]["reply"]["error"]
    rejected = [m.data for m in messages if m.kind == "events"]
    assert any(e["type"] == "rejected_command" and "no_such_task" in e["message"] for e in rejected)
    times = [m.t for m in messages]
    assert times == sorted(times)  # written in sim-time order


def test_a_file_that_is_not_a_recording_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty.mcap"
    from mcap.writer import Writer

    with path.open("wb") as f:
        writer = Writer(f)
        writer.start()
        writer.finish()
    with pytest.raises(ValueError, match="not a lab recording"):
        replay(path)
