"""`lab teleop`: drive the lab server from a terminal.

Keys (velocity in the robot's heading frame, pushes along world axes on the base link):
  w / s  forward / back        a / d  strafe left / right      q / e  turn left / right
  space  stop                  i / k  push +x / -x             j / l  push +y / -y
  g      gait: stand -> trot -> crawl -> biped_step -> stand, skipping those the robot cannot
         run (Bolt: stand <-> biped_step); the velocity keys steer the walking gaits
  r      reset                 p      pause / resume           x      quit (also Ctrl-C, EOF)
  n      next lab (behind a router: the labs seen are listed, offline ones marked)
Velocity is resent every 0.1 s while non-zero (the server's deadman stops the robot 0.5 s after
the last one). Each reply is printed (a walking gait may install the walking stack preset); a
status line shows the lab, the latest telemetry, the running gait among it.
"""

import argparse
import math
import os
import select
import sys
import termios
import time
import tty
from dataclasses import dataclass, replace

import msgspec
import zenoh

from lab.client import LabClient, LabNotFound
from lab.directory import next_online
from lab.protocol import (
    DEFAULT_ENDPOINT,
    PUSH_FORCE_MAX,
    VX_MAX,
    VY_MAX,
    YAW_RATE_MAX,
    CommandStruct,
    GaitCommand,
    LabIdError,
    PauseCommand,
    PushCommand,
    ResetCommand,
    ResumeCommand,
    VelocityCommand,
)

VX_STEP = 0.1  # m/s per key press
VY_STEP = 0.1  # m/s
YAW_STEP = 0.2  # rad/s
PUSH_DURATION_S = 0.2
REFRESH_S = 0.1  # resend a non-zero velocity this often
PUSH_DIRECTIONS = {"i": (1.0, 0.0), "k": (-1.0, 0.0), "j": (0.0, 1.0), "l": (0.0, -1.0)}
GAIT_CYCLE = ("stand", "trot", "crawl", "biped_step")  # the order the `g` key steps through
QUIT_KEYS = ("x", "\x03", "\x04")
NEXT_LAB_KEY = "n"
BASE_LINK_NAMES = ("base", "base_link", "trunk", "pelvis")  # the usual names of a floating base


@dataclass(frozen=True)
class TeleopState:
    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0
    paused: bool = False
    gait: str = "stand"  # the gait last asked for and not rejected

    def velocity(self) -> VelocityCommand:
        """The velocity command of this state."""
        return VelocityCommand(self.vx, self.vy, self.yaw_rate)


def wire(command: CommandStruct) -> str:
    """A command's payload as it goes on the wire (the fields given: defaults are left out)."""
    return msgspec.json.encode(command).decode()


def _step(value: float, step: float, limit: float) -> float:
    return round(min(limit, max(-limit, value + step)), 6)


def next_gait(gait: str) -> str:
    """The gait after `gait` in `GAIT_CYCLE`; `stand` after any other behaviour."""
    if gait not in GAIT_CYCLE:
        return GAIT_CYCLE[0]
    return GAIT_CYCLE[(GAIT_CYCLE.index(gait) + 1) % len(GAIT_CYCLE)]


def key_to_commands(
    key: str, state: TeleopState, body: str, push_force: float
) -> tuple[TeleopState, list[CommandStruct]]:
    """The new state and the commands (lab.protocol structs) one key press sends; unknown keys send
    nothing."""
    velocity_keys = {
        "w": ("vx", VX_STEP, VX_MAX),
        "s": ("vx", -VX_STEP, VX_MAX),
        "a": ("vy", VY_STEP, VY_MAX),
        "d": ("vy", -VY_STEP, VY_MAX),
        "q": ("yaw_rate", YAW_STEP, YAW_RATE_MAX),
        "e": ("yaw_rate", -YAW_STEP, YAW_RATE_MAX),
    }
    if key in velocity_keys:
        field, step, limit = velocity_keys[key]
        state = replace(state, **{field: _step(getattr(state, field), step, limit)})
        return state, [state.velocity()]
    if key == " ":
        state = replace(state, vx=0.0, vy=0.0, yaw_rate=0.0)
        return state, [state.velocity()]
    if key in PUSH_DIRECTIONS:
        dx, dy = PUSH_DIRECTIONS[key]
        force = (dx * push_force, dy * push_force, 0.0)
        return state, [PushCommand(body, force, PUSH_DURATION_S)]
    if key == "g":
        state = replace(state, gait=next_gait(state.gait))
        return state, [GaitCommand(state.gait)]
    if key == "r":  # the server resets to standing
        return TeleopState(paused=state.paused), [ResetCommand()]
    if key == "p":
        return replace(state, paused=not state.paused), [
            ResumeCommand() if state.paused else PauseCommand()
        ]
    return state, []


def acknowledged(
    state: TeleopState, before: TeleopState, command: CommandStruct, reply: dict
) -> TeleopState:
    """The state once the server replied to `command`: a rejected gait keeps the one `before`."""
    if isinstance(command, GaitCommand) and not reply.get("ok"):
        return replace(state, gait=before.gait)
    return state


def default_push_body(bodies: list[str]) -> str:
    """The floating base among `info`'s bodies, by its usual names; else the first body."""
    return next((name for name in BASE_LINK_NAMES if name in bodies), bodies[0])


def labs_line(labs: dict[str, bool], current: str) -> str:
    """The labs seen (id -> online), the one driven starred, offline ones marked."""
    names = [
        ("*" if lab_id == current else "") + lab_id + ("" if online else " (offline)")
        for lab_id, online in labs.items()
    ]
    return f"labs: {', '.join(names)}"


def status_line(
    telemetry: dict | None, state: TeleopState, lab: str = "", online: bool = True
) -> str:
    """One line: the lab (OFFLINE when gone), sim time, gait, base height and world velocity,
    command, QP and loop health."""
    cmd = f"cmd vx {state.vx:+.1f} vy {state.vy:+.1f} wz {state.yaw_rate:+.1f}"
    prefix = f"[{lab}{'' if online else ' OFFLINE'}] " if lab else ""
    if telemetry is None:
        return f"{prefix}(no telemetry yet) {state.gait} {cmd}"
    base = telemetry["base"]
    v = base["linear_velocity"]
    on_time = telemetry.get("loop", {}).get("on_time_fraction", math.nan)
    flags = " PAUSED" if telemetry["paused"] else ""
    flags += " FELL" if telemetry["fell"] else ""
    return (
        f"{prefix}t {telemetry['t']:7.2f}s {telemetry['robot']} {telemetry['gait']} "
        f"z {base['position'][2]:.3f}m "
        f"v [{v[0]:+.2f} {v[1]:+.2f}] {cmd} | qp {telemetry['status']['status']} "
        f"{telemetry['qp']['solve_us']:.0f}us | on-time {on_time:.4f}"
        f"{flags}"
    )


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="lab teleop", description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    p.add_argument("--connect", default=DEFAULT_ENDPOINT, help="Zenoh endpoint of the server")
    p.add_argument(
        "--lab-id", help="the lab to drive first (default: the only one, or the first by id)"
    )
    p.add_argument("--push-force", type=float, default=150.0, help="N (default: 150)")
    p.add_argument("--body", help="link to push (default: the robot's base link)")
    return p


def teleop_main(argv: list[str]) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not 0.0 < args.push_force <= PUSH_FORCE_MAX:  # the push command's range
        parser.error(f"--push-force {args.push_force:g}: must be in (0, {PUSH_FORCE_MAX:g}] N")
    try:
        lab = LabClient(args.connect, lab_id=args.lab_id, first=True, role="teleop")
    except (LabNotFound, LabIdError, zenoh.ZError) as error:  # ZError: client.LabUnreachable,
        print(f"lab teleop: {error}", file=sys.stderr)  # or a LAB_ZENOH_CONFIG Zenoh refuses
        return 1
    with lab:
        print(__doc__.split("\n\n")[1])
        started = _start(lab, args.body)
        if started is None:
            return 1
        fd = sys.stdin.fileno()
        saved = termios.tcgetattr(fd) if sys.stdin.isatty() else None
        if saved is not None:
            tty.setcbreak(fd)
        try:
            _run(lab, *started, args.push_force, fd, args.body)
        finally:
            if saved is not None:
                termios.tcsetattr(fd, termios.TCSADRAIN, saved)
            print()
    return 0


def _start(lab: LabClient, body: str | None) -> tuple[TeleopState, str] | None:
    """The state and push body of the lab `lab` drives now, from its `info` (None if it does
    not answer)."""
    print(f"\r\x1b[K{labs_line(lab.labs(), lab.lab_id)}")
    info = lab.command("info")
    if not info.get("ok"):
        print(f"lab teleop: {lab.lab_id}: info failed: {info.get('error')}", file=sys.stderr)
        return None
    state = TeleopState(paused=bool(info.get("paused", False)), gait=info["gait"])
    return state, body or default_push_body(info["bodies"])


def _run(
    lab: LabClient,
    state: TeleopState,
    body: str,
    push_force: float,
    fd: int,
    body_asked: str | None,
) -> None:
    last_sent = time.monotonic()
    while True:
        ready, _, _ = select.select([fd], [], [], REFRESH_S)
        if ready:
            data = os.read(fd, 1).decode(errors="replace")
            if not data or data in QUIT_KEYS:
                return
            if data == NEXT_LAB_KEY:
                following = next_online(lab.labs(), lab.lab_id)
                if following is None or following == lab.lab_id:
                    print(f"\r\x1b[Kno other lab online; {labs_line(lab.labs(), lab.lab_id)}")
                    continue
                if not state.velocity().is_zero:  # the lab left behind stops
                    lab.send(VelocityCommand())
                lab.select(following)
                started = _start(lab, body_asked)
                state, body = started if started is not None else (TeleopState(), body)
                continue
            before = state
            state, commands = key_to_commands(data, state, body, push_force)
            for command in commands:
                reply = lab.send(command)
                print(f"\r\x1b[K{command.VERB} {wire(command)} -> {reply}")
                # a gait this robot cannot run: the next one of the cycle, until one is taken
                for _ in range(len(GAIT_CYCLE) - 2):
                    gait = isinstance(command, GaitCommand)
                    if not gait or reply.get("ok") or state.gait == before.gait:
                        break
                    state, [command] = key_to_commands("g", state, body, push_force)
                    reply = lab.send(command)
                    print(f"\r\x1b[K{command.VERB} {wire(command)} -> {reply}")
                state = acknowledged(state, before, command, reply)
                last_sent = time.monotonic()
        if not state.velocity().is_zero and time.monotonic() - last_sent > REFRESH_S:
            lab.send(state.velocity())
            last_sent = time.monotonic()
        line = status_line(lab.latest_telemetry(), state, lab.lab_id, lab.connected)
        print(f"\r\x1b[K{line}", end="", flush=True)
