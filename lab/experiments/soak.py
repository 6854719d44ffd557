"""`lab soak`: a long fast-mode run of the real loop under random valid commands and pushes.

The session runs in `SimLoop` exactly as in `lab serve --fast`, behind a transport that plays a
random user instead of Zenoh: every ~COMMAND_INTERVAL_S of sim time it sends a valid command
(velocity, gait, push, stack preset, hierarchy method, momentum mode, gains, scene, pause and
resume, the internal force's reference and source, and on a biped with flat soles a stance and
its leg swing), encodes everything the loop publishes as the server would, and watches telemetry.
Times are sim time run so far (a reset restarts the session's clock, not the soak's). A fall is
answered as a user would: `reset` after FALLEN_S (the robot stands up under the controller the
random user left); if RESET_CHECK_S later it is still down, the default hierarchy method and scene
and the page's "Default stack" (the `robot` command: the robot's default stack and gains);
RESET_CHECK_S after that it must stand (else it is a fall it cannot reset from). The resident memory
is sampled every MEMORY_SAMPLE_S of sim time; growth is measured from the end of the warm-up to the
end. docs/reliability.md has the numbers.
"""

import argparse
import json
import math
import os
import random
import signal
import sys
import threading
import time
from dataclasses import asdict, dataclass, field

from lab.controller.tasks.internal_force import SENSED_SOURCES
from lab.protocol import LIMITS, SWING_HZ_MAX, CommandError, parse_command
from lab.runtime.loop import LoopConfig, SimLoop
from lab.runtime.transport import Request, encode

COMMAND_INTERVAL_S = 0.5  # mean sim time between two commands (exponentially distributed)
FALLEN_S = 1.0  # sim time a fallen robot lies before the soak resets it
RESET_CHECK_S = 1.0  # sim time after a reset when the robot must stand again
STANDING_FRACTION = 0.8  # standing: base at least this fraction of its standing height
MEMORY_SAMPLE_S = 10.0  # sim time between two samples of the resident memory
WARMUP_FRACTION = 0.2  # the first part of the run, whose memory growth does not count
MAX_MEMORY_GROWTH = 0.05  # after the warm-up
PUSH_MAX_FRACTION_OF_WEIGHT = 0.4  # horizontal pushes up to this fraction of the robot's weight
PROGRESS_S = 60.0  # sim time between two progress lines (with --progress)
# Relative frequencies of the commands the random user sends.
VERB_WEIGHTS = {
    "velocity": 6,
    "push": 4,
    "gait": 3,
    "stack": 1,
    "hierarchy": 1,
    "momentum": 1,
    "gains": 1,
    "pause": 1,
    "scene": 0.1,
    "internal_force": 0.5,
    "stance": 0.5,  # drawn only for a robot with two flat soles (the others refuse it)
}
STANCE_SIDES = ("double", "left", "right")


def _count(counts: dict[str, int], key: str) -> None:
    counts[key] = counts.get(key, 0) + 1


def _controller_of(telemetry: dict) -> str:
    """What ran when a plain reset did not stand the robot up: method, gait and scene."""
    method = (telemetry.get("hierarchy") or {}).get("method", "?")
    return f"{method} / {telemetry.get('gait', '?')} / {telemetry.get('scene', '?')}"


def resident_bytes() -> int:
    """This process's resident memory (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@dataclass
class SoakReport:
    """What a soak did and found; `ok` when no check failed (`failures` says which did)."""

    robot: str
    seed: int
    sim_seconds: float
    wall_seconds: float = 0.0
    ticks: int = 0
    commands: dict[str, int] = field(default_factory=dict)  # sent, by verb
    rejected: dict[str, int] = field(default_factory=dict)  # by verb
    events: dict[str, int] = field(default_factory=dict)  # by type
    falls: int = 0
    resets_after_fall: int = 0
    down_after_plain_reset: int = 0  # still down after `reset`, under the user's controller
    plain_reset_failed_under: dict[str, int] = field(default_factory=dict)  # by method, gait
    unrecovered_falls: int = 0  # still down RESET_CHECK_S after a reset to the defaults
    divergences: int = 0
    qp_failures: int = 0
    rss_mb: dict[str, float] = field(default_factory=dict)  # warm (after warm-up), end, max
    memory_growth: float = 0.0  # (end - warm) / warm
    loop: dict = field(default_factory=dict)  # the loop's statistics at the end
    error: str | None = None  # the loop's exception, if it stopped on one
    interrupted: bool = False  # stopped early by SIGINT / SIGTERM
    failures: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.failures


class RandomUser:
    """The soak's transport: commands from a seeded random user, publications encoded and read."""

    def __init__(
        self,
        info: dict,
        weight_n: float,
        standing_height: float,
        sim_seconds: float,
        seed: int,
        flat_soles: bool = False,
    ) -> None:
        self.info = info
        self.verbs = {v: w for v, w in VERB_WEIGHTS.items() if v != "stance" or flat_soles}
        self.weight_n = weight_n
        self.standing_height = standing_height
        self.end = sim_seconds
        self.random = random.Random(seed)
        self.report = SoakReport(info["robot"], seed, sim_seconds)
        self.stop = threading.Event()
        self.progress = False
        self.methods: list[str] = []  # the hierarchy methods the user picks from (all if empty)
        self.sim_time = 0.0  # sim time run so far (the session's clock restarts at 0 on a reset)
        self._session_t = 0.0
        self._next_command = 0.0
        self._queue: list[tuple[str, dict]] = []
        self._fell_at: float | None = None
        self._check_at: float | None = None  # sim time of the standing check after a reset
        self._checking_defaults = False  # the reset being checked restored the defaults
        self._unpausing = False  # a reset is on its way to a paused session
        self._next_sample = 0.0
        self._next_progress = PROGRESS_S
        self._rss: list[tuple[float, int]] = []
        self._wall_start = time.monotonic()

    # ------------------------------------------------------------ the loop's transport
    def receive(self) -> Request | None:
        while self._queue:
            verb, payload = self._queue.pop(0)
            _count(self.report.commands, verb)
            try:  # validated here, as the server's intake thread does
                return Request(verb, payload, None, None, parse_command(verb, payload))
            except CommandError:
                _count(self.report.rejected, verb)
        return None

    def rejections(self) -> tuple[int, str, str]:
        return (0, "", "")

    def reply(self, request: Request, body: dict[str, object]) -> None:
        encode(body)
        if not body.get("ok"):
            _count(self.report.rejected, request.verb)

    def publish_telemetry(self, message: dict[str, object]) -> None:
        encode(message)
        session_t = float(message["t"])
        self.sim_time += session_t - self._session_t if session_t >= self._session_t else session_t
        self._session_t, t = session_t, self.sim_time
        self.report.ticks = message["loop"]["ticks"]
        self.report.divergences = message["divergences"]
        self.report.qp_failures = message["qp"]["failures"]
        self._watch(message)
        if t >= self._next_sample:
            self._rss.append((t, resident_bytes()))
            self._next_sample += MEMORY_SAMPLE_S
        if self.progress and t >= self._next_progress:
            self._next_progress += PROGRESS_S
            rss = self._rss[-1][1] / 2**20
            wall = time.monotonic() - self._wall_start
            print(f"soak: sim {t:.0f} s, wall {wall:.0f} s, rss {rss:.1f} MB", file=sys.stderr)
        if t >= self.end:
            self.report.loop = dict(message["loop"])
            self.stop.set()

    def publish_state(self, message: dict[str, object]) -> None:
        encode(message)

    def publish_event(self, message: dict[str, object]) -> None:
        encode(message)
        _count(self.report.events, str(message["type"]))

    # ------------------------------------------------------------ the random user
    def _watch(self, telemetry: dict) -> None:
        """Reset after a fall and check that the robot stands after that; unpause a session a
        divergence paused; otherwise send a random command when one is due."""
        t = self.sim_time
        if telemetry["paused"]:  # only a repeated divergence pauses (pause-resume is one tick)
            if not self._unpausing:
                self._queue.append(("reset", {}))
                self._unpausing = True
            return
        self._unpausing = False
        if self._check_at is not None:
            if t >= self._check_at:
                self._check_at = None
                down = telemetry["base"]["position"][2] < self.standing_height * STANDING_FRACTION
                if (telemetry["fell"] or down) and self._checking_defaults:
                    self.report.unrecovered_falls += 1
                elif telemetry["fell"] or down:  # the user's controller cannot stand it up
                    self.report.down_after_plain_reset += 1
                    _count(self.report.plain_reset_failed_under, _controller_of(telemetry))
                    self._queue.append(("hierarchy", {"method": self.info["hierarchy"]["method"]}))
                    scene = self.info.get("scene")
                    if telemetry.get("scene", scene) != scene:  # e.g. Bolt's wedges under ANYmal
                        self._queue.append(("scene", {"name": scene}))
                    self._queue.append(("robot", {"name": self.info["robot"]}))
                    self._check_at = t + RESET_CHECK_S
                self._checking_defaults = self._check_at is not None
            return
        if telemetry["fell"]:
            if self._fell_at is None:
                self._fell_at = t
                self.report.falls += 1
            elif t - self._fell_at >= FALLEN_S:
                self._queue.append(("reset", {}))
                self.report.resets_after_fall += 1
                self._fell_at, self._check_at = None, t + RESET_CHECK_S
            return
        if t >= self._next_command:
            self._queue.extend(self._random_commands())
            self._next_command = t + self.random.expovariate(1.0 / COMMAND_INTERVAL_S)

    def _random_commands(self) -> list[tuple[str, dict]]:
        r, info = self.random, self.info
        verb = r.choices(list(self.verbs), weights=list(self.verbs.values()))[0]
        if verb == "velocity":
            limits = {k: r.uniform(-LIMITS[k], LIMITS[k]) / 2 for k in ("vx", "vy", "yaw_rate")}
            return [(verb, limits)]
        if verb == "push":
            force, angle = (
                r.uniform(0.0, PUSH_MAX_FRACTION_OF_WEIGHT * self.weight_n),
                r.uniform(-math.pi, math.pi),
            )
            vector = [force * math.cos(angle), force * math.sin(angle), 0.0]
            return [
                (verb, {"body": info["base"], "force": vector, "duration": r.uniform(0.05, 0.3)})
            ]
        if verb == "pause":  # applied in one loop iteration: the sim time stops for one tick
            return [("pause", {}), ("resume", {})]
        if verb == "internal_force":
            reference = r.uniform(0.0, PUSH_MAX_FRACTION_OF_WEIGHT * self.weight_n)
            return [(verb, {"reference": reference, "source": r.choice(SENSED_SOURCES)})]
        if verb == "stance":
            swing = r.choice((None, 0.0, r.uniform(0.0, SWING_HZ_MAX)))
            return [(verb, {"side": r.choice(STANCE_SIDES), "swing": swing})]
        choices = {
            "gait": ("name", info["gaits"]),
            "stack": ("preset", info["stack_presets"]),
            "hierarchy": ("method", self.methods or info["methods"]),
            "momentum": ("mode", info["momentum_modes"]),
            "scene": ("name", info["scenes"]),
        }
        if verb in choices:
            key, names = choices[verb]
            return [(verb, {key: r.choice(names)})]
        task = r.choice([task for task in info["tasks"] if task["kp"] is not None])
        return [(verb, {"task": task["name"], "kp": task["kp"] * r.uniform(0.5, 2.0)})]

    # ------------------------------------------------------------ the findings
    def finish(self, loop_error: BaseException | None) -> SoakReport:
        report = self.report
        report.wall_seconds = time.monotonic() - self._wall_start
        report.error = None if loop_error is None else repr(loop_error)
        samples = self._rss or [(0.0, resident_bytes())]
        warm_up = WARMUP_FRACTION * min(self.end, self.sim_time)  # of the run, if cut short
        warm = next((b for t, b in samples if t >= warm_up), samples[-1][1])
        end = samples[-1][1]
        report.rss_mb = {
            "warm": round(warm / 2**20, 1),
            "end": round(end / 2**20, 1),
            "max": round(max(b for _, b in samples) / 2**20, 1),
        }
        report.memory_growth = (end - warm) / warm
        if report.error:
            report.failures.append(f"the loop stopped: {report.error}")
        if self.sim_time < self.end:
            why = " (interrupted)" if report.interrupted else ""
            report.failures.append(f"sim time reached only {self.sim_time:.1f} s{why}")
        if report.unrecovered_falls:
            report.failures.append(f"{report.unrecovered_falls} fall(s) a reset did not undo")
        if report.memory_growth > MAX_MEMORY_GROWTH:
            report.failures.append(f"memory grew {report.memory_growth:.1%} after the warm-up")
        if report.qp_failures < report.events.get("solver_failure", 0):  # each event: >= 1 tick
            report.failures.append(
                f"qp_failures {report.qp_failures} < {report.events['solver_failure']} "
                "solver_failure events: the count is not the session's whole"
            )
        return report


def soak(
    robot: str,
    sim_seconds: float,
    seed: int = 0,
    progress: bool = False,
    methods: list[str] | None = None,
) -> SoakReport:
    """Run the loop in fast mode for `sim_seconds` of sim time under a random user (SIGINT or
    SIGTERM end it early, with a report) who picks hierarchy methods from `methods` (default:
    all). Call it from the main thread."""
    from lab.world.session import Session, SessionConfig  # heavy: MuJoCo, pinocchio

    session = Session(SessionConfig(robot=robot))
    weight, height = session.model.mass * 9.81, float(session.robot.q_standing[2])
    contacts = session.model.contacts
    flat_soles = len(contacts) == 2 and all(contact.kind == "flat" for contact in contacts)
    user = RandomUser(session.info(), weight, height, sim_seconds, seed, flat_soles)
    user.progress = progress
    unknown = set(methods or ()) - set(user.info["methods"])
    if unknown:
        raise KeyError(f"unknown method(s) {', '.join(sorted(unknown))}: {user.info['methods']}")
    user.methods = list(methods or ())

    def interrupt(*_: object) -> None:
        user.report.interrupted = True
        user.stop.set()

    previous = {sig: signal.signal(sig, interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    loop = SimLoop(session, user, LoopConfig(fast=True))
    try:
        loop.run(user.stop)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return user.finish(loop.error)


def soak_main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="lab soak", description=__doc__.split("\n\n")[0])
    parser.add_argument("--sim-seconds", type=float, default=3600.0, help="sim time to run (s)")
    parser.add_argument("--robot", default="anymal", help="robot (default: anymal)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random user")
    parser.add_argument("--json", action="store_true", help="print the report as one JSON object")
    parser.add_argument("--progress", action="store_true", help="a line per sim minute on stderr")
    parser.add_argument(
        "--methods",
        help="comma-separated hierarchy methods the random user picks from (default: all; "
        "nullspace, in Python with an active set, runs ticks 10-100x slower than cascade)",
    )
    args = parser.parse_args(argv)
    if not args.sim_seconds > 0:
        print("lab soak: --sim-seconds must be positive", file=sys.stderr)
        return 2
    try:
        methods = args.methods.split(",") if args.methods else None
        report = soak(args.robot, args.sim_seconds, args.seed, args.progress, methods)
    except KeyError as error:
        print(f"lab soak: {error.args[0]}", file=sys.stderr)
        return 2
    data = asdict(report) | {"ok": report.ok}
    if args.json:
        print(json.dumps(data))
    else:
        for key, value in data.items():
            print(f"{key}: {value}")
    return 0 if report.ok else 1
