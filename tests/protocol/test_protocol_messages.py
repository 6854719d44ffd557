"""The typed message set (lab/protocol): every command decodes from valid JSON into its struct
and names the verb, the field and what was wrong otherwise; every reply, telemetry and state
message and event a session (and its loop) sends fits its struct; the page names only events
the server sends."""

import json
import math
import threading

import msgspec
import pytest

from lab.controller import hierarchy
from lab.controller.qp import QPFailure
from lab.protocol import (
    COMMANDS,
    REPLAY_COMMANDS,
    VERBS,
    CommandError,
    CommandStruct,
    FloorCommand,
    GainsCommand,
    GaitCommand,
    HandCommand,
    HierarchyCommand,
    InfoCommand,
    InternalForceCommand,
    MomentumCommand,
    PauseCommand,
    PayloadCommand,
    PushCommand,
    RealismCommand,
    RecordCommand,
    ReleaseCommand,
    ResetCommand,
    ResumeCommand,
    RobotCommand,
    SceneCommand,
    SeekCommand,
    SpeedCommand,
    StackCommand,
    StanceCommand,
    TakeCommand,
    VelocityCommand,
    parse_command,
    parse_replay_command,
)
from lab.protocol.events import EVENT_KINDS, decode_event
from lab.protocol.messages import InfoReply, Reply, State, Telemetry, decode
from lab.protocol.validation import ERROR_MAX_LEN
from lab.runtime.loop import LoopConfig, SimLoop
from lab.ui.app import INFO_CHANGING_VERBS, MOTION_ENDING_VERBS
from lab.ui.event_log import RECURRING_EVENTS, SERVER_EVENTS
from lab.ui.render_loop import MOTION_ENDING_EVENTS
from lab.world.session import Session, SessionConfig

# One valid command of each verb (adding a verb adds its example here).
EXAMPLES: dict[str, CommandStruct] = {
    "info": InfoCommand(),
    "velocity": VelocityCommand(0.5, -0.2, 0.1),
    "push": PushCommand("base", (0.0, 80.0, 0.0), 0.2, (0.1, 0.0, 0.5)),
    "robot": RobotCommand("solo12"),
    "scene": SceneCommand("rough"),
    "hierarchy": HierarchyCommand("nullspace", "daqp", "qdd_tau", "python"),
    "stack": StackCommand((("contact",), ("com", "posture"))),
    "gains": GainsCommand("posture", kp=10.0, weight=2.0),
    "reset": ResetCommand(),
    "pause": PauseCommand(),
    "resume": ResumeCommand(),
    "gait": GaitCommand("trot", step_height=0.1, cycle_time=0.5, footholds="raibert"),
    "momentum": MomentumCommand("lqr"),
    "record": RecordCommand("start"),
    "internal_force": InternalForceCommand(reference=-20.0, source="torques"),
    "stance": StanceCommand("left", 0.25),
    "floor": FloorCommand(3.0),
    "hand": HandCommand(
        "left", (0.4, 0.2, 1.0), (0.0, 0.1, 0.0), 0.05, 3.0, (0.0, 1.0, 0.0), "heading"
    ),
    "take": TakeCommand(),
    "release": ReleaseCommand(),
    "realism": RealismCommand(
        preset="typical", command_delay=2, actuator="sea", estimator="ekf", accel_noise=1e-3
    ),
    "payload": PayloadCommand("base", 10.0, (0.0, 0.0, 0.15)),
}
# One valid command of each verb a served recording takes (`lab replay --serve`).
REPLAY_EXAMPLES: dict[str, CommandStruct] = {
    "info": InfoCommand(),
    "pause": PauseCommand(),
    "resume": ResumeCommand(),
    "speed": SpeedCommand(2.5),
    "seek": SeekCommand(0.25),
}
# A value no field of any command takes.
WRONG = {"a": [1]}


def test_every_verb_has_one_struct_and_round_trips_through_json() -> None:
    assert set(EXAMPLES) == set(VERBS) == set(COMMANDS)
    for verb, command in EXAMPLES.items():
        assert verb == command.VERB and isinstance(command, COMMANDS[verb])
        payload = json.loads(msgspec.json.encode(command))  # what a client sends
        assert parse_command(verb, payload) == command, verb


def test_every_replay_verb_has_one_struct_and_round_trips_through_json() -> None:
    assert set(REPLAY_EXAMPLES) == set(REPLAY_COMMANDS)
    for verb, command in REPLAY_EXAMPLES.items():
        assert verb == command.VERB and isinstance(command, REPLAY_COMMANDS[verb])
        payload = json.loads(msgspec.json.encode(command))  # what a client sends
        assert parse_replay_command(verb, payload) == command, verb


@pytest.mark.parametrize(
    ("verb", "payload", "message"),
    [
        ("speed", {"factor": 0}, "speed: field 'factor' = 0 is out of range (0, 100]"),
        ("speed", {"factor": 250.0}, "speed: field 'factor' = 250 is out of range (0, 100]"),
        ("speed", {"factor": math.nan}, "speed: field 'factor' must be finite, got nan"),
        ("speed", {"factor": True}, "speed: field 'factor' must be a number, got bool"),
        ("speed", {"rate": 2}, "speed: unknown field(s) 'rate' (expected factor)"),
        ("seek", {"t": "soon"}, "seek: field 't' must be a number, got str"),
        ("seek", {"t": math.inf}, "seek: field 't' must be finite, got inf"),
        ("seek", {}, "seek: field 't' is missing"),
        ("seek", [0.5], "seek: payload must be a JSON object, got list"),
        ("pause", {"now": True}, "pause: unknown field(s) 'now' (expected no fields)"),
        (
            "push",
            {"body": "base"},
            "push: a recording is read-only (replay commands: info, pause, resume, speed, seek)",
        ),
    ],
)
def test_a_served_recording_names_the_verb_the_field_and_what_was_wrong(
    verb: str, payload: object, message: str
) -> None:
    with pytest.raises(CommandError) as error:
        parse_replay_command(verb, payload)
    assert str(error.value) == message


@pytest.mark.parametrize("verb", VERBS)
def test_a_wrong_field_or_value_is_named_with_the_verb(verb: str) -> None:
    """For every field of every verb: a value of the wrong type is refused naming the verb and
    the field; an unknown field is refused naming it and the fields there are."""
    valid = json.loads(msgspec.json.encode(EXAMPLES[verb]))
    for field in COMMANDS[verb].__struct_fields__:
        with pytest.raises(CommandError) as error:
            parse_command(verb, {**valid, field: WRONG})
        message = str(error.value)
        assert message.startswith(f"{verb}: field '{field}' must be "), message
        assert message.endswith("got dict"), message
    with pytest.raises(CommandError) as error:
        parse_command(verb, {**valid, "zzz": 1})
    expected = ", ".join(COMMANDS[verb].__struct_fields__) or "no fields"
    # cut at the protocol's error length (realism's knobs run past it)
    whole = f"{verb}: unknown field(s) 'zzz' (expected {expected})"
    assert str(error.value) == whole[:ERROR_MAX_LEN]


@pytest.mark.parametrize(
    ("verb", "payload", "message"),
    [
        ("velocity", {"vx": 2.5}, "velocity: field 'vx' = 2.5 is out of range [-2, 2]"),
        ("velocity", {"yaw_rate": math.nan}, "velocity: field 'yaw_rate' must be finite, got nan"),
        (
            "push",
            {"body": "base", "force": [0, 0, 1], "duration": 1, "point": [0, 0, 1e4]},
            "push: field 'point[2]' = 10000 is out of range [-1000, 1000]",
        ),
        ("gait", {"name": "trot", "cycle_time": 0}, "gait: field 'cycle_time' = 0 is out of "),
        ("record", {"action": "rewind"}, "record: field 'action' must be one of start, stop"),
        ("stance", {"swing": -1}, "stance: field 'swing' = -1 is out of range [0, 1]"),
        ("internal_force", {}, "internal_force: give at least one of 'reference', 'source'"),
        ("stack", {"levels": [["a", "a"]]}, "stack: field 'levels[0]' repeats task 'a'"),
        (  # an optional field is left out for its default, never null
            "push",
            {"body": "base", "force": [0, 0, 1], "duration": 1, "point": None},
            "push: field 'point' must be a list, got null",
        ),
        ("gains", {"task": "com", "kp": None}, "gains: field 'kp' must be a number, got null"),
    ],
)
def test_a_range_a_choice_or_a_rule_names_what_was_wrong(
    verb: str, payload: dict, message: str
) -> None:
    with pytest.raises(CommandError) as error:
        parse_command(verb, payload)
    assert str(error.value).startswith(message), str(error.value)


def test_a_refused_command_changes_nothing_in_the_session() -> None:
    session = Session(SessionConfig(robot="anymal", kernel="python"))
    before = {k: v for k, v in session.info().items() if k != "t"}
    for verb, payload in [
        ("gains", {"task": "posture", "kp": -1.0}),
        ("stack", {"levels": [["contact"], ["nope"]]}),
        ("hierarchy", {"method": "weighted", "solver": "nope"}),
        ("velocity", {"vx": 1.0, "vy": math.inf}),
    ]:
        reply = session.handle(verb, payload)
        assert not reply["ok"] and reply["error"].startswith(f"{verb}: ")
        decode(reply, Reply)
    assert {k: v for k, v in session.info().items() if k != "t"} == before
    assert session.velocity.tolist() == [0.0, 0.0, 0.0]


def _run(session: Session, seconds: float) -> None:
    for _ in range(round(seconds / session.config.timestep)):
        session.tick()


def test_every_message_and_event_of_a_session_fits_its_struct(monkeypatch) -> None:
    """A short headless session: info, every verb's reply, telemetry (a push in progress),
    state, and the events of a refusal, a reset, a solver failure and a divergence."""
    session = Session(SessionConfig(robot="anymal", kernel="python"))
    info = decode({"ok": True, **session.info()}, InfoReply)
    assert info.robot == "anymal" and "push" not in info.known
    _run(session, 0.05)
    for verb in ("velocity", "push", "gains", "gait", "momentum", "pause", "resume", "stack"):
        reply = session.handle(verb, json.loads(msgspec.json.encode(EXAMPLES[verb])))
        decode(reply, Reply)
    session.handle("stack", {"preset": "raiola_s3"})
    session.handle("push", {"body": "base", "force": [0.0, 60.0, 0.0], "duration": 0.5})
    _run(session, 0.05)
    telemetry = decode(json.loads(msgspec.json.encode(session.telemetry())), Telemetry)
    assert telemetry.pushes and telemetry.pushes[0].body == "base"
    state = decode(json.loads(msgspec.json.encode(session.drawing_state())), State)
    assert len(state.frames.names) == len(state.frames.positions) > 10
    assert not session.handle("robot", {"name": "nope"})["ok"]  # rejected_command
    assert session.handle("reset")["ok"]
    _run(session, 0.05)

    def failing(problem: object, solver: object) -> None:
        raise QPFailure("injected failure")

    monkeypatch.setitem(hierarchy.METHODS, session.controller.config.method, failing)
    _run(session, 0.01)
    monkeypatch.undo()
    session.plant.mj_data.qvel[8] = 1e12  # rad/s: a divergence
    session.tick()
    events = session.pop_events()
    kinds = {event["type"] for event in events}
    assert {"rejected_command", "reset", "solver_failure", "sim_diverged"} <= kinds, kinds
    for event in events:
        typed = decode_event(msgspec.json.encode(event))
        assert typed.t == event["t"] and typed.message == event["message"]


def test_a_fall_event_fits_its_struct() -> None:
    """80 N sideways on 2.5 kg Solo12 for 2 s tips it over within ~0.2 s (test_session)."""
    session = Session(SessionConfig(robot="solo12"))
    session.handle("push", {"body": "base_link", "force": [0.0, 80.0, 0.0], "duration": 2.0})
    _run(session, 1.0)
    falls = [e for e in session.pop_events() if e["type"] == "fall"]
    assert len(falls) == 1
    decode_event(falls[0])


class _Transport:
    """A loop's transport that keeps what is published and reports one refused command."""

    def __init__(self) -> None:
        self.telemetry: list[dict] = []
        self.state: list[dict] = []
        self.events: list[dict] = []
        self._refused = [(1, "velocity", "velocity: field 'vx' = 9 is out of range [-2, 2]")]

    def receive(self) -> None:
        return None

    def rejections(self) -> tuple[int, str, str]:
        return self._refused.pop() if self._refused else (0, "", "")

    def reply(self, request: object, body: dict) -> None: ...

    def publish_telemetry(self, message: dict) -> None:
        self.telemetry.append(message)

    def publish_state(self, message: dict) -> None:
        self.state.append(message)

    def publish_event(self, message: dict) -> None:
        self.events.append(message)


def test_what_the_loop_publishes_fits_the_structs() -> None:
    """Through the realtime loop (fast): telemetry with its `loop` statistics, the state, and
    the loop's own rejected_command event."""
    stop = threading.Event()
    session = Session(SessionConfig(robot="solo12", kernel="python"))
    tick = session.tick

    def tick_then_stop() -> None:
        tick()
        if session.time > 0.3:
            stop.set()

    session.tick = tick_then_stop
    transport = _Transport()
    loop = SimLoop(session, transport, LoopConfig(fast=True))
    loop.run(stop)
    assert loop.error is None
    assert transport.telemetry and transport.state
    for message in transport.telemetry:
        assert decode(msgspec.json.encode(message), Telemetry).loop is not None
    for message in transport.state:
        decode(msgspec.json.encode(message), State)
    assert [e["type"] for e in transport.events] == ["rejected_command"]
    decode_event(msgspec.json.encode(transport.events[0]))


def test_the_page_names_only_events_and_verbs_the_server_has() -> None:
    """The page once handled a `preset` event no server sent."""
    assert set(SERVER_EVENTS) | set(RECURRING_EVENTS) | MOTION_ENDING_EVENTS <= set(EVENT_KINDS)
    assert set(VERBS) >= INFO_CHANGING_VERBS | MOTION_ENDING_VERBS
