"""Every command of the lab, once: one frozen msgspec Struct per verb (the payload's shape, its
ranges as msgspec constraints), and the command ranges they are built from.

A payload is decoded and validated in one step by `lab.protocol.validation.parse_command`;
whether a name exists in the running session (robot, scene, task, link, method, solver, gait)
is the session's business. A struct's `VERB` is the last chunk of its key, `lab/<id>/cmd/<verb>`.
Adding a verb: a struct here, listed in `Command`, and its handler in the session. A served
recording (`lab replay --serve`) takes the verbs of `ReplayCommand`. Over 400 lines: every verb
of the protocol is here, the one page a client reads.
"""

import math
from typing import Annotated, ClassVar, Literal, get_args

from msgspec import Meta, Struct, structs

from lab.protocol.realism import (
    KNOBS,
    PAYLOAD_MASS_MAX,
    PAYLOAD_OFFSET_MAX,
    Actuator,
    Estimator,
    RealismPreset,
)

# ---------------------------------------------------------------------------------- command ranges
VX_MAX = 2.0  # m/s, |vx|
VY_MAX = 1.0  # m/s, |vy|
YAW_RATE_MAX = 2.0  # rad/s, |yaw_rate|
PUSH_FORCE_MAX = 2000.0  # N, Euclidean norm of the push force
PUSH_DURATION_MAX = 5.0  # s, 0 < duration <= max
POINT_COORD_MAX = 1000.0  # m, |x|, |y|, |z| of a push application point (world)
HAND_RADIUS_MAX = 1.0  # m, 0 <= radius of a hand target's circle <= max
HAND_PERIOD_MAX = 60.0  # s, 0 < period of a hand target's circle <= max
GAIN_MAX = 1e5  # 0 <= kp, kd <= max
WEIGHT_MAX = 1e8  # 0 < weight <= max
NAME_MAX_LEN = 128  # characters in a robot / scene / task / link / method / gait name
STACK_MAX_LEVELS = 16
STACK_MAX_TASKS = 64  # task names over all levels
STEP_HEIGHT_MAX = 0.5  # m, 0 < step_height <= max (the behaviour checks it against the legs)
CYCLE_TIME_MAX = 5.0  # s, 0 < cycle_time <= max
SWING_HZ_MAX = 1.0  # Hz, 0 <= stance swing <= max (Herzog's leg swing: 0.25 Hz)
FLOOR_SECONDS_MIN, FLOOR_SECONDS_MAX = 0.5, 10.0  # s, the `floor` command's range
SPEED_MAX = 100.0  # times the recorded pace: a served recording's `speed`
SEEK_T_MAX = 1e9  # s, |t| of a served recording's `seek` (then clamped to the recording)

LIMITS: dict[str, float] = {
    "vx": VX_MAX,
    "vy": VY_MAX,
    "yaw_rate": YAW_RATE_MAX,
    "push_force": PUSH_FORCE_MAX,
    "push_duration": PUSH_DURATION_MAX,
    "gain": GAIN_MAX,
    "weight": WEIGHT_MAX,
}  # reported by `info` so clients can size sliders

NAME_PATTERN = r"^[A-Za-z0-9_.:/-]+$"
Name = Annotated[
    str,
    Meta(
        min_length=1,
        max_length=NAME_MAX_LEN,
        pattern=NAME_PATTERN,
        description="a robot, scene, task, link, method or gait name",
    ),
]
ForceCoord = Annotated[float, Meta(ge=-PUSH_FORCE_MAX, le=PUSH_FORCE_MAX)]
PointCoord = Annotated[float, Meta(ge=-POINT_COORD_MAX, le=POINT_COORD_MAX)]
Angle = Annotated[float, Meta(ge=-2 * math.pi, le=2 * math.pi)]
Gain = Annotated[float, Meta(ge=0.0, le=GAIN_MAX)]
Weight = Annotated[float, Meta(gt=0.0, le=WEIGHT_MAX)]
Level = Annotated[tuple[Name, ...], Meta(min_length=1, max_length=STACK_MAX_TASKS)]
RecordAction = Literal["start", "stop"]
RECORD_ACTIONS: tuple[str, ...] = get_args(RecordAction)
# Where a hand target is given: the world, or the trunk's heading frame (origin at the base,
# axes turned by its yaw: the target moves with the robot; lab/controller/tasks/hands.py).
HandFrame = Literal["world", "heading"]


class CommandStruct(Struct, frozen=True, forbid_unknown_fields=True, omit_defaults=True):
    """A command's payload. Every number field has a range, which a NaN or an infinity fails."""

    VERB: ClassVar[str]


class InfoCommand(CommandStruct, frozen=True):
    """Ask for robots, scenes, hierarchy methods, solvers, the current stack with gains, state."""

    VERB: ClassVar[str] = "info"


class VelocityCommand(CommandStruct, frozen=True):
    """Desired base velocity in the heading frame: vx forward, vy left (m/s), yaw_rate (rad/s);
    a missing one is 0."""

    VERB: ClassVar[str] = "velocity"
    vx: Annotated[float, Meta(ge=-VX_MAX, le=VX_MAX, description="m/s, forward")] = 0.0
    vy: Annotated[float, Meta(ge=-VY_MAX, le=VY_MAX, description="m/s, left")] = 0.0
    yaw_rate: Annotated[float, Meta(ge=-YAW_RATE_MAX, le=YAW_RATE_MAX, description="rad/s")] = 0.0

    def payload(self) -> dict[str, float]:
        """The `velocity` command's JSON payload (every component, zeros included)."""
        return {"vx": self.vx, "vy": self.vy, "yaw_rate": self.yaw_rate}

    @property
    def is_zero(self) -> bool:
        """Whether it asks the robot to stand still."""
        return self.vx == 0.0 and self.vy == 0.0 and self.yaw_rate == 0.0


class PushCommand(CommandStruct, frozen=True):
    """External force (N, world frame) on a link for `duration` seconds, at `point` (world) or
    at the link origin when `point` is None."""

    VERB: ClassVar[str] = "push"
    body: Annotated[Name, Meta(description="URDF link name")]
    force: Annotated[
        tuple[ForceCoord, ForceCoord, ForceCoord],
        Meta(description=f"N, world frame, norm <= {PUSH_FORCE_MAX:g}"),
    ]
    duration: Annotated[float, Meta(gt=0.0, le=PUSH_DURATION_MAX, description="s")]
    point: (
        Annotated[
            tuple[PointCoord, PointCoord, PointCoord],
            Meta(description="m, world frame (default: the link origin)"),
        ]
        | None
    ) = None

    def __post_init__(self) -> None:
        norm = math.hypot(*self.force)
        if norm > PUSH_FORCE_MAX:  # the per-axis bound lets a norm up to √3 times it through
            raise ValueError(f"field 'force' norm {norm:g} N exceeds {PUSH_FORCE_MAX:g} N")


class RobotCommand(CommandStruct, frozen=True):
    """Switch robot (one of `info.robots`): rebuilds the session."""

    VERB: ClassVar[str] = "robot"
    name: Name


class SceneCommand(CommandStruct, frozen=True):
    """Switch scene (one of `info.scenes`): rebuilds the session; with `setup`, the controller
    set-up the scene was made for (lab/scenes/setups.py) is installed before its first tick."""

    VERB: ClassVar[str] = "scene"
    name: Name
    setup: bool = False


class HierarchyCommand(CommandStruct, frozen=True):
    """Switch hierarchy method (and QP solver, `nullspace` formulation, kernel when given);
    a kernel alone keeps the method."""

    VERB: ClassVar[str] = "hierarchy"
    method: Name | None = None
    solver: Name | None = None
    formulation: Name | None = None
    kernel: Name | None = None

    def __post_init__(self) -> None:
        if self.method is None and self.kernel is None:
            raise ValueError("field 'method' is missing (give a method, a kernel or both)")


class StackCommand(CommandStruct, frozen=True):
    """New task priority order: levels[0] is the highest priority. Or, with `preset`, a named
    stack from stacks/ (its levels, gains and hierarchy method)."""

    VERB: ClassVar[str] = "stack"
    levels: Annotated[
        tuple[Level, ...],
        Meta(min_length=1, max_length=STACK_MAX_LEVELS, description="highest priority first"),
    ] = ()
    preset: Annotated[Name, Meta(description="one of info.stack_presets")] | None = None

    def __post_init__(self) -> None:
        if self.preset is not None:
            if self.levels:
                raise ValueError("give either 'levels' or 'preset', not both")
            return
        if not self.levels:
            raise ValueError("field 'levels' is missing")
        seen: set[str] = set()
        for i, level in enumerate(self.levels):
            for name in level:
                if name in seen:
                    raise ValueError(f"field 'levels[{i}]' repeats task {name!r}")
                seen.add(name)
        if len(seen) > STACK_MAX_TASKS:
            raise ValueError(f"field 'levels' has more than {STACK_MAX_TASKS} tasks")


class GainsCommand(CommandStruct, frozen=True):
    """Change a task's PD gains and/or weight; fields left None are unchanged."""

    VERB: ClassVar[str] = "gains"
    task: Name
    kp: Gain | None = None
    kd: Gain | None = None
    weight: Weight | None = None

    def __post_init__(self) -> None:
        if self.kp is None and self.kd is None and self.weight is None:
            raise ValueError("give at least one of 'kp', 'kd', 'weight'")


class MomentumCommand(CommandStruct, frozen=True):
    """Choose the momentum task's feedback law: `pd` (Herzog eq. 22) or `lqr` (eqs. 23–26)."""

    VERB: ClassVar[str] = "momentum"
    mode: Annotated[Name, Meta(description="one of info.momentum_modes")]


class InternalForceCommand(CommandStruct, frozen=True):
    """Set the internal force between point feet (Kim 2016 §IV): its reference F_int,ref (N,
    > 0 pushing the feet apart) and where the sensed value comes from (`contacts` or `torques`);
    None keeps the current one. The feedback gain K_F is the `internal_force` task's kp."""

    VERB: ClassVar[str] = "internal_force"
    reference: Annotated[float, Meta(ge=-PUSH_FORCE_MAX, le=PUSH_FORCE_MAX)] | None = None
    source: Name | None = None

    def __post_init__(self) -> None:
        if self.reference is None and self.source is None:
            raise ValueError("give at least one of 'reference', 'source'")


class StanceCommand(CommandStruct, frozen=True):
    """Stand on both soles or lift one (Herzog 2016 §5.4): `double`, `left` or `right` (a biped
    with flat feet; the stance sole is the one named). `swing` (Hz, None: unchanged) swings the
    lifted leg's hip and knee in single support, 0 stops it. Either may be left out (None)."""

    VERB: ClassVar[str] = "stance"
    side: Annotated[Name, Meta(description="double, left or right")] | None = None
    swing: Annotated[float, Meta(ge=0.0, le=SWING_HZ_MAX, description="Hz")] | None = None

    def __post_init__(self) -> None:
        if self.side is None and self.swing is None:
            raise ValueError("give a 'side', a 'swing' frequency or both")


class HandCommand(CommandStruct, frozen=True):
    """Set the target of one hand of the `hands` task: `name` (a hand of the robot's
    description), `position` (m; finite, out of reach is the controller's to handle), `rpy`
    (rad, roll-pitch-yaw; None keeps the target's rotation matrix, read in `frame`); with
    `radius` > 0 (m) the position circles about `position` once per `period` (s),
    counter-clockwise in the plane normal to `axis`. All in `frame`: the world, or the trunk's
    heading frame (origin at the base, axes turned by its yaw), which carries the target along
    as the robot walks."""

    VERB: ClassVar[str] = "hand"
    name: Annotated[Name, Meta(description="a hand of the robot's description (info.hands)")]
    position: Annotated[tuple[PointCoord, PointCoord, PointCoord], Meta(description="m, in frame")]
    rpy: (
        Annotated[tuple[Angle, Angle, Angle], Meta(description="rad, roll-pitch-yaw in frame")]
        | None
    ) = None
    radius: Annotated[float, Meta(ge=0.0, le=HAND_RADIUS_MAX, description="m")] = 0.0
    period: Annotated[float, Meta(gt=0.0, le=HAND_PERIOD_MAX, description="s")] = 4.0
    axis: Annotated[
        tuple[PointCoord, PointCoord, PointCoord],
        Meta(description="the circle plane's normal (in frame)"),
    ] = (1.0, 0.0, 0.0)
    frame: Annotated[
        HandFrame, Meta(description="world, or heading: the trunk's position and yaw")
    ] = "world"

    def __post_init__(self) -> None:
        if math.hypot(*self.axis) < 1e-6:
            raise ValueError("field 'axis' must not be zero")


class ResetCommand(CommandStruct, frozen=True):
    """Put the robot back at its standing posture and clear pushes and velocity commands."""

    VERB: ClassVar[str] = "reset"


class PauseCommand(CommandStruct, frozen=True):
    """Stop advancing simulated time (the loop keeps running and publishing)."""

    VERB: ClassVar[str] = "pause"


class ResumeCommand(CommandStruct, frozen=True):
    """Advance simulated time again after a pause."""

    VERB: ClassVar[str] = "resume"


class GaitCommand(CommandStruct, frozen=True):
    """Switch behaviour / gait (e.g. stand, trot, crawl); a walking gait also takes its step
    height (m), cycle time (s) and foothold planner (None = keep or default)."""

    VERB: ClassVar[str] = "gait"
    name: Annotated[Name, Meta(description="one of info.gaits")]
    step_height: Annotated[float, Meta(gt=0.0, le=STEP_HEIGHT_MAX, description="m")] | None = None
    cycle_time: Annotated[float, Meta(gt=0.0, le=CYCLE_TIME_MAX, description="s")] | None = None
    footholds: Annotated[Name, Meta(description="robocentric or raibert")] | None = None

    def options(self) -> dict[str, float | str]:
        """The walking options given (step_height, cycle_time, footholds), by name."""
        given = {
            "step_height": self.step_height,
            "cycle_time": self.cycle_time,
            "footholds": self.footholds,
        }
        return {key: value for key, value in given.items() if value is not None}


class RecordCommand(CommandStruct, frozen=True):
    """Start or stop recording the live session to an MCAP file (`lab serve` picks the file,
    in its recording directory, and names it in the reply)."""

    VERB: ClassVar[str] = "record"
    action: RecordAction


class TakeCommand(CommandStruct, frozen=True):
    """Take the control lock (docs/protocol.md, "The control lock"): refused while another
    client holds it."""

    VERB: ClassVar[str] = "take"


class ReleaseCommand(CommandStruct, frozen=True):
    """Release the control lock this client holds."""

    VERB: ClassVar[str] = "release"


class FloorCommand(CommandStruct, frozen=True):
    """Measure the machine's floor: the loop's on-time fraction with nothing to do, for
    `seconds` (the session stands still meanwhile; lab/runtime/floor.py). The reply carries it."""

    VERB: ClassVar[str] = "floor"
    seconds: Annotated[float, Meta(ge=FLOOR_SECONDS_MIN, le=FLOOR_SECONDS_MAX, description="s")] = (
        2.0
    )


def _knob(name: str) -> Meta:
    """The msgspec constraint of realism knob `name` (lab/protocol/realism.py)."""
    knob = KNOBS[name]
    return Meta(ge=knob.lo, le=knob.hi, description=f"{knob.unit}: {knob.meaning}")


class RealismCommand(CommandStruct, frozen=True):
    """Set the realism knobs (docs/realism.md): `preset` (None: the knobs running now) with any
    knob over it, the actuator model and the state estimator (`true`: the measured true state;
    `ekf`: the base estimated from the IMU and leg kinematics). A change of mass_error,
    com_error or seed rebuilds the controller's model (the robot stands again)."""

    VERB: ClassVar[str] = "realism"
    preset: RealismPreset | None = None
    actuator: Actuator | None = None
    estimator: Estimator | None = None
    gyro_noise: Annotated[float, _knob("gyro_noise")] | None = None
    gyro_bias_walk: Annotated[float, _knob("gyro_bias_walk")] | None = None
    accel_noise: Annotated[float, _knob("accel_noise")] | None = None
    accel_bias_walk: Annotated[float, _knob("accel_bias_walk")] | None = None
    attitude_noise: Annotated[float, _knob("attitude_noise")] | None = None
    base_velocity_noise: Annotated[float, _knob("base_velocity_noise")] | None = None
    base_position_noise: Annotated[float, _knob("base_position_noise")] | None = None
    encoder_bits: Annotated[int, _knob("encoder_bits")] | None = None
    encoder_noise: Annotated[float, _knob("encoder_noise")] | None = None
    velocity_differencing: Annotated[int, _knob("velocity_differencing")] | None = None
    velocity_filter_hz: Annotated[float, _knob("velocity_filter_hz")] | None = None
    measurement_delay: Annotated[int, _knob("measurement_delay")] | None = None
    command_delay: Annotated[int, _knob("command_delay")] | None = None
    torque_bandwidth_hz: Annotated[float, _knob("torque_bandwidth_hz")] | None = None
    sea_stiffness: Annotated[float, _knob("sea_stiffness")] | None = None
    sea_motor_inertia: Annotated[float, _knob("sea_motor_inertia")] | None = None
    sea_kp: Annotated[float, _knob("sea_kp")] | None = None
    sea_kd: Annotated[float, _knob("sea_kd")] | None = None
    contact_estimate: Annotated[int, _knob("contact_estimate")] | None = None
    torque_saturation: Annotated[float, _knob("torque_saturation")] | None = None
    coulomb_friction: Annotated[float, _knob("coulomb_friction")] | None = None
    viscous_friction: Annotated[float, _knob("viscous_friction")] | None = None
    mass_error: Annotated[float, _knob("mass_error")] | None = None
    com_error: Annotated[float, _knob("com_error")] | None = None
    seed: Annotated[int, _knob("seed")] | None = None

    def __post_init__(self) -> None:
        if self.preset is None and not self.knobs():
            raise ValueError("give a 'preset', knobs or both")

    def knobs(self) -> dict[str, float | int | str]:
        """The knobs given (the actuator included), by name."""
        given = structs.asdict(self)
        return {k: v for k, v in given.items() if k != "preset" and v is not None}


PayloadOffset = Annotated[float, Meta(ge=-PAYLOAD_OFFSET_MAX, le=PAYLOAD_OFFSET_MAX)]


class PayloadCommand(CommandStruct, frozen=True):
    """Fix a payload of `mass` kg at `offset` (m, in link `body`'s frame) in the simulator only
    (a box on the back, a weight in a hand); 0 kg removes it. The controller is not told."""

    VERB: ClassVar[str] = "payload"
    body: Annotated[Name, Meta(description="a link, one of info.bodies")]
    mass: Annotated[float, Meta(ge=0.0, le=PAYLOAD_MASS_MAX, description="kg")]
    offset: tuple[PayloadOffset, PayloadOffset, PayloadOffset] = (0.0, 0.0, 0.0)


Command = (
    InfoCommand
    | VelocityCommand
    | PushCommand
    | RobotCommand
    | SceneCommand
    | HierarchyCommand
    | StackCommand
    | GainsCommand
    | ResetCommand
    | PauseCommand
    | ResumeCommand
    | GaitCommand
    | MomentumCommand
    | RecordCommand
    | InternalForceCommand
    | StanceCommand
    | HandCommand
    | TakeCommand
    | ReleaseCommand
    | FloorCommand
    | RealismCommand
    | PayloadCommand
)
COMMANDS: dict[str, type[CommandStruct]] = {cls.VERB: cls for cls in get_args(Command)}
VERBS: tuple[str, ...] = tuple(COMMANDS)


# ------------------------------------------------------------------ a served recording's verbs
class SpeedCommand(CommandStruct, frozen=True):
    """A served recording (`lab replay --serve`) only: play at `factor` times the recorded
    pace."""

    VERB: ClassVar[str] = "speed"
    factor: Annotated[float, Meta(gt=0.0, le=SPEED_MAX, description="times the recorded pace")]


class SeekCommand(CommandStruct, frozen=True):
    """A served recording (`lab replay --serve`) only: jump to `t` (clamped to the recording);
    the newest telemetry and drawing state at or before it are published at once."""

    VERB: ClassVar[str] = "seek"
    t: Annotated[
        float, Meta(ge=-SEEK_T_MAX, le=SEEK_T_MAX, description="s of the recording's sim time")
    ]


# What a served recording answers to: the playback's verbs; every other is refused (read-only).
ReplayCommand = InfoCommand | PauseCommand | ResumeCommand | SpeedCommand | SeekCommand
REPLAY_COMMANDS: dict[str, type[CommandStruct]] = {cls.VERB: cls for cls in get_args(ReplayCommand)}

# Verbs any client may send while another holds the control lock: they change nothing in the
# world (a recording watches it).
READ_ONLY_VERBS = (InfoCommand.VERB, RecordCommand.VERB, TakeCommand.VERB, ReleaseCommand.VERB)
