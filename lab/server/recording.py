"""Recording a session to MCAP, and replaying a recording through a session.

A recording holds, on the protocol's own topics, what a live lab publishes: telemetry
(`lab/telemetry`, with the joint torques of that tick), the drawing state (`lab/state`), events
(`lab/events`) and every command with its reply (`lab/commands`): the names of the messages,
without the lab id that scopes them on Zenoh (`lab/<id>/telemetry`), so a recording is served
again under any lab id (`lab replay --serve --lab-id`). Messages are JSON with a JSON
schema per topic, the encodings Foxglove and PlotJuggler open without configuration. Log times
are the session clock (ns since the session started), so a recording's timeline is sim time.
The session's configuration and limits are the metadata record `session`, so a recording can be
replayed through a new session: same commands at the same ticks, and on one machine the same
torques (the tick is deterministic there).
"""

import json
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import IO

import numpy as np
from mcap.reader import make_reader
from mcap.writer import Writer

from lab.server.commands import CommandError, parse_command
from lab.server.limits import apply_limits
from lab.server.session import Session, SessionConfig
from lab.server.transport import Request, ServerTransport, encode

TOPICS = {
    "telemetry": "lab/telemetry",
    "state": "lab/state",
    "events": "lab/events",
    "commands": "lab/commands",
}
# The fields each topic's messages always have (JSON Schema, draft 2020-12); the rest is
# described in docs/protocol.md. Foxglove and PlotJuggler read the field names from the data.
SCHEMAS = {
    "telemetry": {
        "type": "object",
        "properties": {
            "t": {"type": "number", "description": "session time, s"},
            "tick": {"type": "integer"},
            "tau": {"type": "array", "items": {"type": "number"}, "description": "N m"},
        },
        "required": ["t", "tick", "tau"],
    },
    "state": {
        "type": "object",
        "properties": {"t": {"type": "number"}, "robot": {"type": "string"}},
        "required": ["t"],
    },
    "events": {
        "type": "object",
        "properties": {
            "t": {"type": "number"},
            "type": {"type": "string"},
            "message": {"type": "string"},
        },
        "required": ["t", "type", "message"],
    },
    "commands": {
        "type": "object",
        "properties": {
            "t": {"type": "number"},
            "tick": {"type": "integer"},
            "verb": {"type": "string"},
            "payload": {},
            "reply": {"type": "object"},
        },
        "required": ["t", "tick", "verb", "payload", "reply"],
    },
}
TELEMETRY_PERIOD = 10  # ticks between recorded telemetry messages (100 Hz at 1 kHz)
STATE_PERIOD = 16  # ticks between recorded drawing states (about 60 Hz)
# s: a session time this far below the last one written is a reset (the session clock restarts
# at 0); the recording's timeline then goes on from where it was. Events lag the clock by at most
# one telemetry period (10 ms), far less.
RESET_DROP_S = 0.05


class Recorder:
    """Writes one session to an MCAP file; `close` (or the context manager) finishes it."""

    def __init__(
        self, output: str | Path | IO[bytes], session: Session, limits: dict | None = None
    ) -> None:
        """Start a recording of `session` (already built, with `limits` applied if any)."""
        self._file = open(output, "wb") if isinstance(output, str | Path) else None  # noqa: SIM115
        self._writer = Writer(self._file or output)
        self._writer.start(profile="", library="wbc-lab")
        self._channels = {}
        for kind, topic in TOPICS.items():
            schema = self._writer.register_schema(
                name=f"wbc_lab.{kind}",
                encoding="jsonschema",
                data=json.dumps(SCHEMAS[kind]).encode(),
            )
            self._channels[kind] = self._writer.register_channel(topic, "json", schema)
        self._writer.add_metadata("session", session_metadata(session, limits or {}))
        self._sequence = 0
        # The timeline starts at 0 when the recording does (mid-session too) and goes on
        # across resets: timeline = session time + offset.
        self._last_t = session.time  # the last session time written
        self._offset = -session.time
        self._last_stamp = 0

    def after_tick(self, session: Session) -> None:
        """What a headless run records after each tick: telemetry and the drawing state at
        their rates, and every event."""
        if session.ticks % TELEMETRY_PERIOD == 0:
            self.telemetry(session)
        if session.ticks % STATE_PERIOD == 0:
            self.state(session)
        self.events(session.pop_events())

    def telemetry(self, session: Session, message: dict | None = None) -> None:
        """This tick's telemetry (`message`, if already built) with its joint torques."""
        message = {**(message or session.telemetry()), "tick": session.ticks}
        message["tau"] = session.tau.tolist()
        self._write("telemetry", session.time, message)

    def state(self, session: Session, message: dict | None = None) -> None:
        """This tick's drawing state (`message`, if already built)."""
        self._write("state", session.time, message or session.drawing_state())

    def events(self, events: list[dict]) -> None:
        for event in events:
            self._write("events", event["t"], event)

    def command(self, session: Session, verb: str, payload: object, reply: dict) -> None:
        """A command as received (before the next tick) and the reply it got."""
        message = {"t": session.time, "tick": session.ticks, "verb": verb, "payload": payload}
        self._write("commands", session.time, {**message, "reply": reply})

    def _write(self, kind: str, t: float, message: dict) -> None:
        """Log time: the session time `t` on a timeline that never runs back (a reset restarts
        the session clock, the timeline goes on)."""
        if t < self._last_t - RESET_DROP_S:
            self._offset += self._last_t
        self._last_t = t
        stamp = self._last_stamp = max(self._last_stamp, round((t + self._offset) * 1e9))
        data = encode(message)  # the transport's encoder: non-finite floats as null, valid JSON
        self._sequence += 1
        self._writer.add_message(self._channels[kind], stamp, data, stamp, self._sequence)

    @property
    def seconds(self) -> float:
        """Length of the timeline written so far (s)."""
        return self._last_stamp / 1e9

    def close(self) -> None:
        self._writer.finish()
        if self._file is not None:
            self._file.close()

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


class RecordingTransport:
    """The sim loop's transport with a recorder beside it (`lab serve`): what the loop publishes
    and every reply it sends are written too, on the loop's thread, while a recording runs.

    `lab serve --record FILE` starts one at once; the `record` command (`{"action": "start"}` /
    `{"action": "stop"}`, the page's Record button) starts and stops one at any time, in
    `record_dir`, named after the robot and the wall-clock time. A recording started mid-session
    is for watching (`lab replay --serve`, Foxglove, PlotJuggler), not for re-running: its
    metadata is the session's configuration, not the state the recording began in. Telemetry
    carries `recording: {file, seconds}` while one runs (null otherwise), so every browser
    shows it."""

    def __init__(
        self,
        transport: ServerTransport,
        session: Session,
        record_dir: Path,
        recorder: Recorder | None = None,
        path: Path | None = None,
    ) -> None:
        self._transport = transport
        self._session = session
        self._record_dir = record_dir
        self._recorder, self._path = recorder, path

    def receive(self) -> Request | None:
        while (request := self._transport.receive()) is not None:
            if request.verb != "record" or request.error is not None:
                return request
            try:
                reply = self._record(request.payload)
            except Exception as error:  # a recorder fault is a refused command, never a stop
                reply = {"ok": False, "error": f"record: {type(error).__name__}: {error}"}
            self._transport.reply(request, reply)
        return None

    def _record(self, payload: object) -> dict[str, object]:
        try:
            command = parse_command("record", payload)
        except CommandError as error:
            return {"ok": False, "error": str(error)}
        if command.action == "start":
            if self._recorder is not None:
                return {"ok": False, "error": f"record: already recording to {self._path}"}
            robot = self._session.config.robot
            path = self._record_dir / f"lab-{robot}-{time.strftime('%Y%m%d-%H%M%S')}.mcap"
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                self._recorder = Recorder(path, self._session)
            except OSError as error:
                return {"ok": False, "error": f"record: cannot write {path}: {error}"}
            self._path = path
            return {"ok": True, "recording": {"file": str(path), "seconds": 0.0}}
        if self._recorder is None:
            return {"ok": False, "error": "record: nothing is being recorded"}
        seconds = self._recorder.seconds
        self.close()
        size = self._path.stat().st_size
        reply = {"file": str(self._path), "seconds": round(seconds, 3), "bytes": size}
        return {"ok": True, "recorded": reply}

    def close(self) -> None:
        """Finish the running recording, if any."""
        if self._recorder is not None:
            self._recorder.close()
            self._recorder = None

    def rejections(self) -> tuple[int, str, str]:
        return self._transport.rejections()

    def reply(self, request: Request, body: dict[str, object]) -> None:
        if self._recorder is not None:
            self._recorder.command(self._session, request.verb, request.payload, body)
        self._transport.reply(request, body)

    def publish_telemetry(self, message: dict[str, object]) -> None:
        status = None
        if self._recorder is not None:
            self._recorder.telemetry(self._session, message)
            status = {"file": str(self._path), "seconds": round(self._recorder.seconds, 2)}
        self._transport.publish_telemetry({**message, "recording": status})

    def publish_state(self, message: dict[str, object]) -> None:
        if self._recorder is not None:
            self._recorder.state(self._session, message)
        self._transport.publish_state(message)

    def publish_event(self, message: dict[str, object]) -> None:
        if self._recorder is not None:
            self._recorder.events([message])
        self._transport.publish_event(message)


def session_metadata(session: Session, limits: dict) -> dict[str, str]:
    """What a replay needs to build the same session (its configuration and its limits), and
    the session's `info` when the recording began (what a served replay answers `info` with)."""
    return {
        "config": json.dumps(asdict(session.config)),
        "limits": json.dumps(limits),
        "info": encode(session.info()).decode(),
    }


@dataclass(frozen=True)
class Message:
    """One recorded message: its kind (a key of TOPICS), log time (s) and content."""

    kind: str
    t: float
    data: dict


def read_recording(path: str | Path) -> tuple[dict[str, str], Iterator[Message]]:
    """The `session` metadata and the messages of a recording, in the order they were written
    (a command and the telemetry of one tick share a log time)."""
    kinds = {topic: kind for kind, topic in TOPICS.items()}
    with open(path, "rb") as f:
        reader = make_reader(f)
        metadata = next(
            (record.metadata for record in reader.iter_metadata() if record.name == "session"),
            None,
        )
        if metadata is None:
            raise ValueError(f"{path}: not a lab recording (no 'session' metadata)")
        messages = [
            (
                message.sequence,
                Message(kinds[channel.topic], message.log_time * 1e-9, json.loads(message.data)),
            )
            for _, channel, message in reader.iter_messages(log_time_order=False)
            if channel.topic in kinds
        ]
        messages.sort(key=lambda m: m[0])
    messages = [message for _, message in messages]
    return metadata, iter(messages)


@dataclass(frozen=True)
class ReplayCheck:
    """How a replay through a new session compared with the recording."""

    ticks: int
    commands: int
    compared: int  # telemetry messages whose torques were compared
    max_torque_error: float  # N m
    replies_differ: int  # commands whose reply differs from the recorded one


def replay(path: str | Path) -> ReplayCheck:
    """Run a new session through the recorded commands, tick for tick, and compare its joint
    torques with the recorded telemetry's."""
    metadata, messages = read_recording(path)
    session = Session(SessionConfig(**json.loads(metadata["config"])))
    limits = json.loads(metadata.get("limits", "{}"))
    if limits:
        apply_limits(session.controller, limits)
    commands = compared = differ = 0
    error = 0.0
    for message in messages:
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
    return ReplayCheck(session.ticks, commands, compared, error, differ)
