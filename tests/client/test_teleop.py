"""The teleop key map: which commands each key sends, and that they are valid commands."""

import json

import msgspec
import pytest

from lab.protocol import (
    VX_MAX,
    GaitCommand,
    PushCommand,
    ResetCommand,
    VelocityCommand,
    parse_command,
)
from lab.teleop import (
    PUSH_DURATION_S,
    TeleopState,
    acknowledged,
    default_push_body,
    key_to_commands,
    status_line,
    teleop_main,
)


def press(keys: str, state: TeleopState | None = None) -> tuple[TeleopState, list]:
    state = state or TeleopState()
    sent = []
    for key in keys:
        state, commands = key_to_commands(key, state, body="base", push_force=150.0)
        sent.extend(commands)
    return state, sent


def test_velocity_keys_step_and_clamp() -> None:
    state, sent = press("ww")
    assert state.vx == pytest.approx(0.2)
    assert sent[-1] == VelocityCommand(0.2, 0.0, 0.0)
    state, _ = press("w" * 100)
    assert state.vx == VX_MAX
    state, _ = press("aqq")
    assert (state.vy, state.yaw_rate) == (pytest.approx(0.1), pytest.approx(0.4))
    state, _ = press("sdde", state)
    assert (state.vx, state.vy, state.yaw_rate) == (pytest.approx(-0.1), pytest.approx(-0.1), 0.2)
    state, sent = press(" ", state)
    assert state.velocity() == VelocityCommand()
    assert sent == [VelocityCommand()]


def test_push_keys_push_the_body_along_world_axes() -> None:
    _, sent = press("ikjl")
    forces = [push.force for push in sent if isinstance(push, PushCommand)]
    assert forces == [(150.0, 0, 0), (-150.0, 0, 0), (0, 150.0, 0), (0, -150.0, 0)]
    assert all(p.body == "base" and p.duration == PUSH_DURATION_S for p in sent)


def test_pause_toggles_and_reset_clears_velocity() -> None:
    state, sent = press("wpp")
    assert [command.VERB for command in sent] == ["velocity", "pause", "resume"]
    state, sent = press("p", state)
    assert state.paused
    state, sent = press("r", state)
    assert sent == [ResetCommand()]
    assert state == TeleopState(paused=True)


def test_gait_key_cycles_stand_trot_crawl_biped_step() -> None:
    state, sent = press("ggggg")
    assert [gait.name for gait in sent if isinstance(gait, GaitCommand)] == [
        "trot",
        "crawl",
        "biped_step",
        "stand",
        "trot",
    ]
    assert state.gait == "trot"
    assert press("w", state)[0].gait == "trot"  # other keys keep the gait
    assert press("r", state)[0].gait == "stand"  # the server resets to standing
    _, sent = press("g", TeleopState(gait="height_step"))  # a Hutter experiment behaviour
    assert sent == [GaitCommand("stand")]


def test_a_rejected_gait_keeps_the_previous_one() -> None:
    before = TeleopState(vx=0.2)
    state, [gait] = press("g", before)
    rejected = {"ok": False, "error": "walking needs one foot per quadrant"}
    assert acknowledged(state, before, gait, rejected) == before
    assert acknowledged(state, before, gait, {"ok": True}).gait == "trot"
    pushed, [push] = press("i", before)
    assert acknowledged(pushed, before, push, rejected) == pushed  # only the gait is undone


def test_every_key_sends_valid_commands_and_others_send_nothing() -> None:
    for key in "wsadqe ikjlrpg":
        _, sent = press(key)
        assert sent
        for command in sent:  # what goes on the wire decodes to the same command
            assert parse_command(command.VERB, json.loads(msgspec.json.encode(command))) == command
    assert press("zZ1\x1b")[1] == []


def test_status_line_without_and_with_telemetry() -> None:
    line = status_line(None, TeleopState(gait="crawl"))
    assert "no telemetry" in line and "crawl" in line
    telemetry = {
        "t": 1.5,
        "robot": "anymal",
        "gait": "trot",
        "paused": False,
        "fell": True,
        "base": {"position": [0, 0, 0.45], "linear_velocity": [0.3, -0.1, 0]},
        "status": {"status": "fallback", "level": 1, "reason": "the QP of level 1 failed"},
        "qp": {"solve_us": 120.0},
        "loop": {"on_time_fraction": 0.9995},
    }
    line = status_line(telemetry, TeleopState(vx=0.3))
    assert "z 0.450m" in line and "v [+0.30 -0.10]" in line and "FELL" in line
    assert "anymal trot" in line  # the server's gait, not the teleop's
    assert "0.9995" in line
    assert "qp fallback 120us" in line  # telemetry's one status


def test_default_push_body_is_the_base_link() -> None:
    assert default_push_body(["LF_FOOT", "LF_HAA", "base", "base_inertia"]) == "base"
    assert default_push_body(["arm_left_1_link", "base_link", "torso_1_link"]) == "base_link"
    assert default_push_body(["link_a", "link_b"]) == "link_a"


@pytest.mark.parametrize("force", ["0", "-5", "2500", "nan"])
def test_a_push_force_out_of_the_commands_range_is_refused_at_start(force: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        teleop_main(["--push-force", force])
    assert exit_.value.code == 2 and "--push-force" in capsys.readouterr().err
