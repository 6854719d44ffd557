"""Recording a session to MCAP (its replay: replay.py).

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
from dataclasses import asdict
from pathlib import Path
from typing import IO

from mcap.writer import Writer

from lab.protocol import CommandError, parse_command
from lab.runtime.transport import Request, ServerTransport, encode
from lab.world.session import Session

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
# s of wall time between two chunks written out: a recorder killed (SIGKILL, power cut of the
# process) loses at most this plus one message's interval (read_recording reads the rest).
FLUSH_S = 0.5


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
        self._writer.flush()  # the header and the metadata on disk at once
        self._flushed_at = time.monotonic()
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
        if (now := time.monotonic()) - self._flushed_at >= FLUSH_S:
            self._writer.flush()  # the chunk so far, compressed, to the OS: it survives a kill
            self._flushed_at = now

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
