"""Recording a headless run to MCAP and replaying it through a new session."""

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from lab.cli import main
from lab.experiments.scenario import Event, load_scenario, run_scenario
from lab.recording import record as recording_module
from lab.recording.record import SCHEMAS, TOPICS
from lab.recording.replay import RecordingError, read_recording, replay
from tests.helpers.ports import free_port

SCENARIOS = Path(__file__).resolve().parent.parent.parent / "scenarios"
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
    messages = read_recording(recording).messages
    commands = [m.data for m in messages if m.kind == "commands"]
    assert [c["verb"] for c in commands] == ["gains", "gains", "push"]
    assert [c["reply"]["ok"] for c in commands] == [True, False, True]
    assert "no_such_task" in commands[1]["reply"]["error"]
    rejected = [m.data for m in messages if m.kind == "events"]
    assert any(e["type"] == "rejected_command" and "no_such_task" in e["message"] for e in rejected)
    times = [m.t for m in messages]
    assert times == sorted(times)  # written in sim-time order


@pytest.fixture(scope="module")
def chunked(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """ANYmal standing 0.3 s, every message flushed as a chunk of its own (a headless run is
    faster than the wall-clock flush period), so that a cut anywhere keeps what came before."""
    path = tmp_path_factory.mktemp("chunked") / "run.mcap"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(recording_module, "FLUSH_S", 0.0)
        run_scenario(load_scenario(SCENARIOS / "anymal_stand_cascade.toml"), 0.3, record=path)
    return path


@pytest.mark.parametrize("fraction", [0.2, 0.5, 0.9, "last byte"])
def test_a_truncated_recording_gives_its_readable_prefix_and_says_what_was_lost(
    chunked: Path, tmp_path: Path, fraction: float | str
) -> None:
    whole = read_recording(chunked)
    assert whole.cut_short is None
    data = chunked.read_bytes()
    cut = len(data) - 1 if fraction == "last byte" else int(len(data) * fraction)
    path = tmp_path / "cut.mcap"
    path.write_bytes(data[:cut])
    prefix = read_recording(path)
    kept = len(prefix.messages)
    assert 0 < kept <= len(whole.messages)
    assert prefix.messages == whole.messages[:kept]
    # what is lost is at most the share of the file cut away, and a few messages
    assert kept >= len(whole.messages) * (cut / len(data)) * 0.8 - 5, (kept, cut)
    assert prefix.cut_short == (
        f"the recording ends at {prefix.seconds:.1f} s: cut short after {kept} messages "
        "(the file stops with no summary: killed mid-write?)"
    )


def test_a_truncated_recording_replays_its_prefix_through_the_session(
    chunked: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = chunked.read_bytes()
    path = tmp_path / "cut.mcap"
    path.write_bytes(data[: len(data) // 2])
    assert main(["replay", str(path)]) == 0
    out, err = capsys.readouterr()
    check = json.loads(out)
    assert 0 < check["ticks"] < 300 and check["compared"] > 0
    assert check["max_torque_error"] <= REPLAY_TOL
    assert "cut short after" in check["cut_short"] and "cut short after" in err


def test_a_recording_corrupt_in_the_middle_gives_what_comes_before(
    chunked: Path, tmp_path: Path
) -> None:
    data = bytearray(chunked.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 16] = bytes(16)  # a chunk's data no longer matches its CRC
    path = tmp_path / "corrupt.mcap"
    path.write_bytes(data)
    prefix = read_recording(path)
    whole = read_recording(chunked).messages
    assert 0 < len(prefix.messages) < len(whole)
    assert prefix.messages == whole[: len(prefix.messages)]
    assert "unreadable from about byte" in prefix.cut_short


def _garbage(chunked: Path) -> dict[str, tuple[bytes, str]]:
    """Files that are no recording: their bytes and what the refusal says."""
    magic = b"\x89MCAP0\r\n"
    header_and_metadata = chunked.read_bytes()[:200]
    return {
        "empty": (b"", "not an MCAP file (an empty file)"),
        "text": (b"t,vx\n0.0,0.1\n" * 20, "not an MCAP file (260 bytes starting b't,vx"),
        "bad magic": (b"\x89MCAP9\r\n" + bytes(100), "not an MCAP file"),
        "short": (b"\x89MC", "not an MCAP file (3 bytes"),
        "9 bytes": (magic + b"\x01", "cut short before its session metadata"),
        "corrupt": (magic + bytes(range(256)) * 4, "cut short before its session metadata"),
        "huge length": (magic + b"\x01" + b"\xff" * 8 + bytes(64), "record at byte 8 is longer"),
        "cut in the metadata": (header_and_metadata, "cut short before its session metadata"),
    }


GARBAGE = ["empty", "text", "bad magic", "short", "9 bytes", "corrupt", "huge length",
           "cut in the metadata"]  # fmt: skip


@pytest.mark.parametrize("kind", GARBAGE)
@pytest.mark.parametrize("serve", [False, True])
def test_a_file_that_is_not_a_recording_is_refused_in_one_line(
    chunked: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, serve: bool
) -> None:
    data, says = _garbage(chunked)[kind]
    path = tmp_path / "garbage.mcap"
    path.write_bytes(data)
    argv = ["replay", str(path), *(["--serve", "--port", str(free_port())] if serve else [])]
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("lab replay: "), err
    assert says in err, err


def test_a_recording_that_cannot_be_written_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = str(SCENARIOS / "anymal_stand_cascade.toml")
    where = tmp_path / "no such folder" / "run.mcap"
    assert main(["run", scenario, "--duration", "0.01", "--record", str(where)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lab run: [Errno 2] No such file") and str(where) in err, err


def test_an_mcap_file_without_the_session_metadata_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty.mcap"
    from mcap.writer import Writer

    with path.open("wb") as f:
        writer = Writer(f)
        writer.start()
        writer.finish()
    with pytest.raises(RecordingError, match="not a lab recording"):
        replay(path)
