"""Command validation: every verb's happy path, and each kind of bad input named in the error."""

import math

import pytest

from lab.protocol import (
    GAIN_MAX,
    PUSH_DURATION_MAX,
    PUSH_FORCE_MAX,
    VERBS,
    VX_MAX,
    VY_MAX,
    WEIGHT_MAX,
    YAW_RATE_MAX,
    CommandError,
    FloorCommand,
    GainsCommand,
    HierarchyCommand,
    InfoCommand,
    PushCommand,
    StackCommand,
    VelocityCommand,
    parse_command,
)


def test_floor_takes_seconds_in_its_range_or_its_default() -> None:
    assert parse_command("floor", {}) == FloorCommand(seconds=2.0)
    assert parse_command("floor", {"seconds": 5}) == FloorCommand(seconds=5.0)
    for bad in (0.1, 11.0, "2", math.nan):
        with pytest.raises(CommandError, match="floor: field 'seconds'"):
            parse_command("floor", {"seconds": bad})


def test_verbs_are_the_protocol_verbs() -> None:
    assert set(VERBS) == {
        "info",
        "velocity",
        "push",
        "robot",
        "scene",
        "hierarchy",
        "stack",
        "gains",
        "reset",
        "pause",
        "resume",
        "gait",
        "momentum",
        "internal_force",
        "record",
        "stance",
        "hand",
        "take",
        "release",
        "floor",
        "realism",
        "payload",
    }


def test_record_takes_start_or_stop_and_names_a_wrong_action() -> None:
    assert parse_command("record", {"action": "stop"}).action == "stop"
    for payload, words in (({}, "'action' is missing"), ({"action": "rewind"}, "start, stop")):
        with pytest.raises(CommandError, match=words):
            parse_command("record", payload)


def test_velocity_defaults_missing_components_to_zero() -> None:
    assert parse_command("velocity", {"vx": 0.5}) == VelocityCommand(0.5, 0.0, 0.0)
    assert parse_command("velocity", {}) == VelocityCommand(0.0, 0.0, 0.0)
    cmd = parse_command("velocity", {"vx": -VX_MAX, "vy": VY_MAX, "yaw_rate": 1})
    assert cmd == VelocityCommand(-VX_MAX, VY_MAX, 1.0)
    assert isinstance(cmd.yaw_rate, float)


def test_push_parses_vectors_as_float_tuples() -> None:
    cmd = parse_command("push", {"body": "base", "force": [0, 100, 0], "duration": 0.1})
    assert cmd == PushCommand("base", (0.0, 100.0, 0.0), 0.1, None)
    cmd = parse_command(
        "push", {"body": "LF_SHANK", "force": [1, 2, 3], "duration": 1, "point": [0.1, 0, 0.5]}
    )
    assert cmd.point == (0.1, 0.0, 0.5)


def test_stack_hierarchy_gains_info() -> None:
    cmd = parse_command("stack", {"levels": [["contact"], ["base_orientation", "posture"]]})
    assert cmd == StackCommand((("contact",), ("base_orientation", "posture")))
    assert parse_command("stack", {"preset": "raiola_s3"}) == StackCommand(preset="raiola_s3")
    assert parse_command("hierarchy", {"method": "weighted"}) == HierarchyCommand("weighted")
    cmd = parse_command("hierarchy", {"method": "cascade", "solver": "clarabel"})
    assert cmd == HierarchyCommand("cascade", "clarabel")
    assert parse_command("gains", {"task": "posture", "kd": 3}) == GainsCommand("posture", kd=3.0)
    assert parse_command("info", {}) == InfoCommand()


def test_an_old_spelling_is_rejected_naming_the_new_word() -> None:
    """`method` is the one word for cascade / weighted / nullspace (docs/protocol.md)."""
    with pytest.raises(CommandError, match="field 'hierarchy' is now called 'method'"):
        parse_command("hierarchy", {"hierarchy": "weighted"})


@pytest.mark.parametrize(
    ("verb", "payload", "needle"),
    [
        ("jump", {}, "jump: unknown command"),
        ("velocity", [1, 2], "payload must be a JSON object, got list"),
        ("velocity", None, "got null"),
        ("velocity", {"vz": 1.0}, "unknown field(s) 'vz'"),
        ("velocity", {"vx": True}, "'vx' must be a number, got bool"),
        ("velocity", {"vx": "1"}, "'vx' must be a number, got str"),
        ("velocity", {"vx": math.nan}, "'vx' must be finite"),
        ("velocity", {"yaw_rate": -math.inf}, "'yaw_rate' must be finite"),
        ("velocity", {"vx": VX_MAX + 0.01}, "'vx' = 2.01 is out of range"),
        ("velocity", {"vy": -VY_MAX - 0.01}, "'vy'"),
        ("velocity", {"yaw_rate": YAW_RATE_MAX * 2}, "'yaw_rate'"),
        ("velocity", {"vx": 10**400}, "'vx' is out of range"),
        ("push", {"force": [0, 0, 1], "duration": 0.1}, "'body' is missing"),
        ("push", {"body": "base", "duration": 0.1}, "'force' is missing"),
        ("push", {"body": "base", "force": [0, 0], "duration": 0.1}, "list of 3 numbers"),
        ("push", {"body": "base", "force": [0, 0, None], "duration": 0.1}, "'force[2]'"),
        (
            "push",
            {"body": "base", "force": [PUSH_FORCE_MAX, PUSH_FORCE_MAX, 0], "duration": 0.1},
            "norm",
        ),
        ("push", {"body": "base", "force": [0, 0, 1]}, "'duration' is missing"),
        ("push", {"body": "base", "force": [0, 0, 1], "duration": 0}, "'duration' = 0"),
        (
            "push",
            {"body": "base", "force": [0, 0, 1], "duration": PUSH_DURATION_MAX + 1},
            "'duration'",
        ),
        ("push", {"body": "", "force": [0, 0, 1], "duration": 1}, "'body' must not be empty"),
        ("push", {"body": 3, "force": [0, 0, 1], "duration": 1}, "'body' must be a string"),
        ("push", {"body": "a" * 1000, "force": [0, 0, 1], "duration": 1}, "longer than"),
        ("push", {"body": "a\nb", "force": [0, 0, 1], "duration": 1}, "may only contain"),
        ("robot", {}, "'name' is missing"),
        ("robot", {"name": "anymal", "x": 1}, "unknown field(s) 'x'"),
        ("scene", {"name": ["flat"]}, "'name' must be a string, got list"),
        ("hierarchy", {"solver": "daqp"}, "'method' is missing"),
        ("stack", {}, "'levels' is missing"),
        ("stack", {"preset": 3}, "'preset' must be a string"),
        ("stack", {"preset": "raiola_s3", "levels": [["contact"]]}, "not both"),
        ("stack", {"levels": []}, "non-empty list"),
        ("stack", {"levels": [[]]}, "'levels[0]' must be a non-empty list"),
        ("stack", {"levels": [["a"], "b"]}, "'levels[1]'"),
        ("stack", {"levels": [["a"], ["b", "a"]]}, "repeats task 'a'"),
        ("stack", {"levels": [["a"], [1]]}, "'levels[1][0]' must be a string"),
        ("stack", {"levels": [[f"t{i}"] for i in range(100)]}, "more than"),
        ("gains", {"task": "posture"}, "at least one"),
        ("gains", {"task": "posture", "kp": -1}, "'kp' = -1 is out of range"),
        ("gains", {"task": "posture", "kd": GAIN_MAX * 10}, "'kd'"),
        ("gains", {"task": "posture", "weight": 0}, "'weight' = 0 is out of range (0"),
        ("gains", {"task": "posture", "weight": WEIGHT_MAX * 10}, "'weight'"),
        ("reset", {"now": True}, "unknown field(s) 'now'"),
        ("pause", {"x": 1}, "unknown field"),
        ("gait", {"name": None}, "'name' must be a string, got null"),
    ],
)
def test_bad_input_is_rejected_with_a_named_reason(verb: str, payload: object, needle: str) -> None:
    with pytest.raises(CommandError) as err:
        parse_command(verb, payload)
    assert needle in str(err.value)
    assert str(err.value).startswith(verb) or "unknown command" in str(err.value)


@pytest.mark.parametrize("field", ["kp", "kd", "weight"])
@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (-5, "is out of range"),
        (1e9, "is out of range"),
        (math.nan, "must be finite"),
        (math.inf, "must be finite"),
    ],
)
def test_gains_out_of_range_or_non_finite_are_rejected_naming_the_limit(
    field: str, value: float, expected: str
) -> None:
    """What the UI's gain boxes refuse the server refuses too, for every client: the error names
    the field and, for a finite value, the range with its limit (the UI once clamped silently)."""
    with pytest.raises(CommandError) as error:
        parse_command("gains", {"task": "com", field: value})
    message = str(error.value)
    assert f"'{field}'" in message and expected in message
    if math.isfinite(value):
        limit = WEIGHT_MAX if field == "weight" else GAIN_MAX
        assert f"{limit:g}]" in message
