"""Reading a recording (record.py writes it) and replaying it through a new session: the readable
prefix of a file cut short (a recorder killed) with what was lost said, one clear error for
anything that is no recording, and the replay's check that the same commands at the same ticks
give the same torques.
"""

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from mcap.exceptions import RecordLengthLimitExceeded
from mcap.records import Channel, Metadata
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader
from mcap.writer import MCAP0_MAGIC

from lab.experiments.limits import apply_limits
from lab.realism.knobs import RealismKnobs
from lab.recording.record import TOPICS
from lab.world.session import Session, SessionConfig

RECORD_PREFIX_BYTES = 9  # an MCAP record's opcode (1) and length (8)


@dataclass(frozen=True)
class Message:
    """One recorded message: its kind (a key of TOPICS), log time (s) and content."""

    kind: str
    t: float
    data: dict


@dataclass(frozen=True)
class Recording:
    """What a recording file holds, read front to back: the `session` metadata and the
    messages in the order they were written (a command and the telemetry of one tick share a
    log time). `cut_short` says what was lost when the file stops early (a recorder killed
    mid-write, a truncated copy, a corrupt record: everything before it is kept); None for a
    complete file."""

    path: str
    metadata: dict[str, str]
    messages: list[Message]
    cut_short: str | None = None

    @property
    def seconds(self) -> float:
        """The log time of the last message (s)."""
        return self.messages[-1].t if self.messages else 0.0


class RecordingError(ValueError):
    """A file that is not a readable lab recording; the message names the file and says what it
    is instead, in one line."""


def read_recording(path: str | Path) -> Recording:
    """Read a recording as a stream, record after record, without its summary: a file whose
    writer was killed, or cut, or corrupt from some record on, gives the messages before the
    first record that cannot be read (a chunk is checked against its CRC) and says so in
    `cut_short`. Chunks are flushed every FLUSH_S, so a killed recorder loses at most that.
    Raises RecordingError for a file that is not an MCAP file, or not a lab recording, or is
    cut before its session metadata; OSError for a file it cannot open."""
    path = Path(path)
    size = path.stat().st_size
    kinds = {topic: kind for kind, topic in TOPICS.items()}
    topics: dict[int, str] = {}  # channel id -> topic
    metadata: dict[str, str] | None = None
    messages: list[Message] = []
    problem: str | None = None
    with path.open("rb") as f:
        head = f.read(len(MCAP0_MAGIC))
        if head != MCAP0_MAGIC:
            what = "an empty file" if size == 0 else f"{size} bytes starting {head!r}"
            raise RecordingError(f"{path}: not an MCAP file ({what})")
        f.seek(0)
        # A record cannot be longer than the file: a corrupt length stops the read at once.
        reader = StreamReader(f, validate_crcs=True, record_size_limit=size)
        try:
            for record in reader.records:
                if isinstance(record, Channel):
                    topics[record.id] = record.topic
                elif isinstance(record, Metadata) and record.name == "session":
                    metadata = record.metadata
                elif isinstance(record, McapMessage) and topics.get(record.channel_id) in kinds:
                    kind = kinds[topics[record.channel_id]]
                    messages.append(Message(kind, record.log_time * 1e-9, json.loads(record.data)))
        except RecordLengthLimitExceeded:  # its opcode and length read, the rest not there
            start = f.tell() - RECORD_PREFIX_BYTES
            problem = (
                f"the record at byte {start} is longer than the file: "
                "the file ends mid-record (killed mid-write?) or is corrupt"
            )
        except Exception as error:  # any record it cannot read ends the readable prefix
            problem = (
                "the file stops with no summary: killed mid-write?"
                if f.tell() >= size
                else f"unreadable from about byte {f.tell()} of {size}: "
                f"{type(error).__name__}: {error}"[:300]
            )
    if metadata is None:
        if problem is not None:
            raise RecordingError(f"{path}: cut short before its session metadata ({problem})")
        raise RecordingError(f"{path}: not a lab recording (no 'session' metadata)")
    recording = Recording(str(path), metadata, messages)
    if problem is None:
        return recording
    cut_short = (
        f"the recording ends at {recording.seconds:.1f} s: cut short after "
        f"{len(messages)} messages ({problem})"
    )
    return replace(recording, cut_short=cut_short)


@dataclass(frozen=True)
class ReplayCheck:
    """How a replay through a new session compared with the recording."""

    ticks: int
    commands: int
    compared: int  # telemetry messages whose torques were compared
    max_torque_error: float  # N m
    replies_differ: int  # commands whose reply differs from the recorded one
    cut_short: str | None  # what the recording lost at its end (Recording.cut_short)


def replay(path: str | Path) -> ReplayCheck:
    """Run a new session through the recorded commands, tick for tick, and compare its joint
    torques with the recorded telemetry's (of the readable prefix of a file cut short)."""
    recording = read_recording(path)
    try:
        fields = json.loads(recording.metadata["config"])
        # the realism knobs as recorded (a recording from before them: ideal)
        fields["realism"] = RealismKnobs(**fields.get("realism", {}))
        config = SessionConfig(**fields)
    except (KeyError, TypeError, ValueError) as error:
        raise RecordingError(
            f"{path}: its session metadata is not a session's ({error!r})"
        ) from error
    session = Session(config)
    limits = json.loads(recording.metadata.get("limits", "{}"))
    if limits:
        apply_limits(session.controller, limits)
    commands = compared = differ = 0
    error = 0.0
    for message in recording.messages:
        if message.kind not in ("commands", "telemetry"):
            continue
        target = message.data["tick"]
        while session.ticks < target:
            session.tick()
        if message.kind == "commands":
            commands += 1
            reply = json.loads(
                json.dumps(session.handle(message.data["verb"], message.data["payload"]))
            )
            differ += reply != message.data["reply"]
        else:
            compared += 1
            recorded = np.array(message.data["tau"])
            error = max(error, float(np.max(np.abs(session.tau - recorded), initial=0.0)))
    return ReplayCheck(session.ticks, commands, compared, error, differ, recording.cut_short)
