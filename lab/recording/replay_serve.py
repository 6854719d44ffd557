"""`lab replay FILE.mcap --serve`: a recording served over the protocol like a live session.

The recorded telemetry, drawing states and events go out on `lab/<id>/telemetry`, `.../state`
and `.../events` (the lab id `--lab-id`, by default `<host>-replay`) at their recorded pace
(times the speed), so the browser UI, `lab.client` scripts and plots follow a recording as they
follow the sim. Commands on `lab/<id>/cmd/<verb>` steer the
playback: `info`, `pause`, `resume`, `speed {factor}`, `seek {t}` (lab.protocol's `ReplayCommand`
structs, validated by `parse_replay_command` off the loop); every other verb is refused (a
recording is read-only). docs/recording.md and docs/protocol.md.
"""

import bisect
import json
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import assert_never, cast

import zenoh

from lab.protocol import (
    SPEED_MAX,
    CommandError,
    InfoCommand,
    LabIdError,
    PauseCommand,
    ReplayCommand,
    ResumeCommand,
    SeekCommand,
    SpeedCommand,
    default_lab_id,
    parse_replay_command,
)
from lab.recording.replay import Message, Recording, RecordingError, read_recording
from lab.runtime.serve import stop_process
from lab.runtime.transport import Request, ServerTransport, server_config

STEP_S = 0.005  # wall time between two publishing steps
# s of wall time: a paused or ended playback publishes its newest telemetry and state again this
# often, so that a page opened later (or a UI process started after a short recording ended)
# shows where the playback is instead of "Waiting for telemetry".
HOLD_REFRESH_S = 0.5
PLAYED_KINDS = ("telemetry", "state", "events")


@dataclass
class Player:
    """A position on a recording's timeline (s of sim time) that advances with wall time."""

    messages: list[Message]
    speed: float = 1.0
    paused: bool = False
    position: float = 0.0
    _times: list[float] = field(default_factory=list)
    _next: int = 0  # index of the next message to publish

    def __post_init__(self) -> None:
        self._times = [m.t for m in self.messages]

    @property
    def duration(self) -> float:
        return self._times[-1] if self._times else 0.0

    @property
    def ended(self) -> bool:
        return self._next >= len(self.messages)

    def advance(self, wall_dt: float) -> list[Message]:
        """The messages due after `wall_dt` more seconds of wall time (none while paused)."""
        if self.paused or self.ended:
            return []
        self.position = min(self.duration, self.position + wall_dt * self.speed)
        end = bisect.bisect_right(self._times, self.position, lo=self._next)
        due, self._next = self.messages[self._next : end], end
        return due

    def seek(self, t: float) -> list[Message]:
        """Move to `t` (clamped to the recording); returns the newest telemetry and drawing state
        at or before it, to show at once."""
        self.position = min(max(t, 0.0), self.duration)
        self._next = bisect.bisect_right(self._times, self.position)
        return self.latest()

    def latest(self) -> list[Message]:
        """The newest telemetry and drawing state at or before the position, oldest first."""
        latest: dict[str, Message] = {}
        for message in reversed(self.messages[: self._next]):
            if message.kind in ("telemetry", "state") and message.kind not in latest:
                latest[message.kind] = message
                if len(latest) == 2:
                    break
        return sorted(latest.values(), key=lambda m: m.t)

    def status(self) -> dict[str, object]:
        return {
            "t": self.position,
            "duration": self.duration,
            "speed": self.speed,
            "paused": self.paused,
            "ended": self.ended,
        }


class ReplayServer:
    """Serves one recording on a transport until stopped."""

    def __init__(
        self, recording: Recording, transport: ServerTransport, speed: float = 1.0
    ) -> None:
        self.path = recording.path
        self.cut_short = recording.cut_short  # what a recording cut short lost, or None
        self.config = json.loads(recording.metadata.get("config", "{}"))
        # older recordings: no info
        self.recorded_info = json.loads(recording.metadata.get("info", "{}"))
        played = [m for m in recording.messages if m.kind in PLAYED_KINDS]
        self.player = Player(played, speed=speed)
        self.transport = transport

    def handle(self, verb: str, payload: object) -> dict[str, object]:
        """Validate and apply one playback command; the reply is the protocol's `{ok, ...}`
        (a refused one changes nothing)."""
        try:
            command = parse_replay_command(verb, {} if payload is None else payload)
        except CommandError as error:
            return {"ok": False, "error": str(error)}
        return self.execute(command)

    def execute(self, command: ReplayCommand) -> dict[str, object]:
        """Apply one playback command already validated (`parse_replay_command`)."""
        player = self.player
        match command:
            case SpeedCommand(factor=factor):
                player.speed = factor
            case SeekCommand(t=t):
                self._publish(player.seek(t))
            case PauseCommand():
                player.paused = True
            case ResumeCommand():
                player.paused = False
            case InfoCommand():
                pass
            case _:  # a replay command without a case here: mypy names it
                assert_never(command)
        status = {"file": self.path, **player.status(), "cut_short": self.cut_short}
        reply: dict[str, object] = {"ok": True, "replay": status}
        if isinstance(command, InfoCommand):  # the recorded session's info, and what it ran
            reply = {**self.recorded_info, **reply, "recorded": self.config}
            reply |= {"paused": player.paused, "t": player.position}
        return reply

    def run(self, stop: threading.Event) -> None:
        """Answer commands and publish what is due every STEP_S until `stop` is set."""
        last = held = time.monotonic()
        while not stop.wait(STEP_S):
            while (request := self.transport.receive()) is not None:
                self._answer(request)
            now = time.monotonic()
            was_ended = self.player.ended
            self._publish(self.player.advance(now - last))
            last = now
            if not (self.player.paused or self.player.ended):
                held = now
            elif now - held >= HOLD_REFRESH_S:
                held = now
                self._publish(self.player.latest())
            if self.player.ended and not was_ended:
                self.transport.publish_event(
                    {
                        "type": "replay_ended",
                        "t": self.player.position,
                        "message": "end of the recording (seek to play it again)",
                    }
                )

    def _answer(self, request: Request) -> None:
        if request.error is not None:
            reply: dict[str, object] = {"ok": False, "error": request.error}
        else:  # the intake validated it: `parse_replay_command`'s struct
            reply = self.execute(cast(ReplayCommand, request.command))
        self.transport.reply(request, reply)

    def _publish(self, messages: list[Message]) -> None:
        publish = {
            "telemetry": self.transport.publish_telemetry,
            "state": self.transport.publish_state,
            "events": self.transport.publish_event,
        }
        status = {"file": self.path, **self.player.status()}
        for message in messages:  # telemetry says where the playback is: the page's timeline
            data = message.data
            if message.kind == "telemetry":
                data = {**data, "replay": status}
            publish[message.kind](data)


def replay_serve_main(
    path: str, port: int, speed: float, lab_id: str | None = None, ui_port: int | None = None
) -> int:
    """Serve `path` on 127.0.0.1:`port` as lab `lab_id` (default `<host>-replay`) until SIGINT
    or SIGTERM, with the browser UI on `ui_port` as `lab serve` starts it (None: headless); 2
    for a recording, a port or a lab id it cannot use."""
    if not 0.0 < speed <= SPEED_MAX:
        print(f"lab replay: --speed must be in (0, {SPEED_MAX:g}]", file=sys.stderr)
        return 2
    try:
        recording = read_recording(path)
    except (OSError, RecordingError) as error:
        print(f"lab replay: {error}", file=sys.stderr)
        return 2
    if recording.cut_short:
        print(f"lab replay: {path}: {recording.cut_short}", file=sys.stderr)
    try:
        transport = ServerTransport(
            server_config(port), lab_id or default_lab_id("replay"), validate=parse_replay_command
        )
    except zenoh.ZError as error:
        print(f"lab replay: Zenoh: {error}", file=sys.stderr)
        return 2
    except LabIdError as error:
        print(f"lab replay: --lab-id: {error}", file=sys.stderr)
        return 2
    ui = None
    try:
        server = ReplayServer(recording, transport, speed)
        stop = threading.Event()
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
        duration = server.player.duration
        endpoint = f"tcp/127.0.0.1:{port}"
        if ui_port is not None:  # the page, as `lab serve` starts it
            ui = subprocess.Popen(
                [sys.executable, "-m", "lab.ui", "--connect", endpoint, "--exit-with-parent",
                 "--port", str(ui_port), "--lab-id", transport.keys.lab_id]
            )  # fmt: skip
        print(f"lab replay: {path} ({duration:.1f} s) on Zenoh {endpoint}", flush=True)
        server.run(stop)
    except (OSError, ValueError, KeyError) as error:
        print(f"lab replay: {error}", file=sys.stderr)
        return 2
    finally:
        transport.close()
        if ui is not None:
            stop_process(ui)
    return 0
