"""Recording and replay in the page.

Live, a Record button asks the sim process to record the session to MCAP (the `record`
command; `lab serve` picks the file and telemetry says what is being recorded, so every browser
sees it). Connected to `lab replay FILE --serve`, the page shows a timeline slider to seek, Play /
Pause and the playback speed instead; telemetry then carries where the playback is.
"""

import time
from collections.abc import Callable

import viser

SPEEDS = ("0.25", "0.5", "1", "2", "5", "10")  # the speed dropdown's choices, × recorded pace
TIMELINE_STEP_S = 0.01
SEEK_HOLD_S = 1.0  # after a seek from the page, the slider is left where the user put it


def recording_text(recording: dict | None, done: dict | None = None) -> str:
    """The line under the Record button for telemetry's `recording` field (`done`: the reply
    to the last stop, what was recorded)."""
    if recording:
        return f"● Recording {recording['seconds']:.1f} s to `{recording['file']}`"
    if done:
        return f"Recorded {done['seconds']:.1f} s to `{done['file']}`"
    return "Not recording. Record writes what the lab publishes to an MCAP file."


def replay_text(replay: dict) -> str:
    """The line under the replay controls for telemetry's `replay` field."""
    state = "ended" if replay["ended"] else "paused" if replay["paused"] else "playing"
    return (
        f"Replay of `{replay['file']}`: {state} at {replay['t']:.2f} / "
        f"{replay['duration']:.2f} s, × {replay['speed']:g}"
    )


class RecordingControls:
    """The page's Recording folder: Record / Stop live, a timeline when replaying.

    `send(client, verb, payload)` sends a command for a browser (the app checks it holds
    control and reports a refusal)."""

    def __init__(
        self,
        gui: viser.GuiApi,
        send: Callable[[viser.ClientHandle, str, dict], dict | None],
        guard: Callable,
    ) -> None:
        self._gui = gui
        self._send = send
        self._guard = guard
        self._folder = gui.add_folder("Recording", order=6.5, expand_by_default=False)
        with self._folder:
            self._record = gui.add_button("Record", hint="start or stop recording to MCAP")
            self._line = gui.add_markdown(recording_text(None))
        self._record.on_click(guard(self._toggle))
        self._recording: dict | None = None  # telemetry's `recording`, as last shown
        self._done: dict | None = None  # the reply to the last stop
        self._timeline: viser.GuiSliderHandle | None = None
        self._play: viser.GuiButtonGroupHandle | None = None
        self._speed: viser.GuiDropdownHandle | None = None
        self._seeked_at = -1e9  # monotonic s of the last seek from a browser

    def _toggle(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        action = "stop" if self._recording else "start"
        reply = self._send(event.client, "record", {"action": action})
        if reply and reply.get("ok") and action == "stop":
            self._done = reply["recorded"]
            self._show_recording(None)

    def show(self, tel: dict) -> None:
        """Follow one telemetry message: the live recording's state, or the replay's."""
        replay = tel.get("replay")
        if replay is not None:
            self._show_replay(replay)
            return
        recording = tel.get("recording")
        if recording and self._done and recording["file"] == self._done["file"]:
            return  # telemetry sent before the stop
        if recording != self._recording:
            self._show_recording(recording)

    def _show_recording(self, recording: dict | None) -> None:
        self._line.content = recording_text(recording, self._done)
        self._record.label = "Stop recording" if recording else "Record"
        self._recording = recording

    def _show_replay(self, replay: dict) -> None:
        if self._timeline is None:
            self._build_replay(replay["duration"])
        self._record.disabled = True
        self._line.content = replay_text(replay)
        if time.monotonic() - self._seeked_at > SEEK_HOLD_S:
            self._timeline.value = min(replay["t"], self._timeline.max)

    def _build_replay(self, duration: float) -> None:
        """The timeline and playback controls, in their own folder at the top of the panel
        (in the collapsed Recording folder far below, nobody found them)."""
        self._folder.visible = False  # a recording is not recorded again
        self._folder = self._gui.add_folder("Replay", order=0.5, expand_by_default=True)
        with self._folder:
            self._timeline = self._gui.add_slider(
                "Timeline [s]", 0.0, max(duration, TIMELINE_STEP_S), TIMELINE_STEP_S, 0.0
            )
            self._play = self._gui.add_button_group("Playback", ("Play", "Pause"))
            self._speed = self._gui.add_dropdown("Speed ×", SPEEDS, initial_value="1")
        self._timeline.on_update(self._guard(self._seek))
        self._play.on_click(self._guard(self._play_pause))
        self._speed.on_update(self._guard(self._set_speed))

    def _seek(self, event: viser.GuiEvent) -> None:
        if event.client is not None:  # dragged in a browser, not moved by the playback
            self._seeked_at = time.monotonic()
            self._send(event.client, "seek", {"t": float(event.target.value)})

    def _play_pause(self, event: viser.GuiEvent) -> None:
        if event.client is not None:
            self._send(event.client, "resume" if event.target.value == "Play" else "pause", {})

    def _set_speed(self, event: viser.GuiEvent) -> None:
        if event.client is not None:
            self._send(event.client, "speed", {"factor": float(event.target.value)})
