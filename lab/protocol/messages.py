"""Every reply, telemetry and state message of a lab, once, as msgspec Structs (docs/protocol.md,
"Replies", "lab/telemetry", "lab/state"). The server builds these messages as plain dicts on
its loop (typing them there costs 15-58 % of their build: docs/protocol.md, "Schemas") and the
tests hold every message a session sends to these types; clients decode with them (`decode`).

One file for the three, over 400 lines, because they share their parts (hierarchy, momentum,
internal force, loop statistics, recording and playback) and it is declarations only, no logic:
split, each part would be imported across three files.
"""

from typing import Annotated, Literal, TypeVar

import msgspec
from msgspec import Meta, Struct

from lab.protocol.realism import Estimator

Vec3 = Annotated[list[float], Meta(min_length=3, max_length=3)]
TickPath = Literal["native", "python"]
QuatXyzw = Annotated[list[float], Meta(min_length=4, max_length=4, description="x, y, z, w")]
Stack = Annotated[list[list[str]], Meta(description="levels, highest priority first")]
KernelName = Literal["native", "python"]


class Message(Struct, frozen=True, forbid_unknown_fields=True):
    """A message of the lab: no field beyond those declared."""


# ---------------------------------------------------------------------------------- shared parts
class Hierarchy(Message, frozen=True):
    """The hierarchy asked for: method, QP solver, nullspace formulation."""

    method: str
    solver: str
    formulation: Annotated[str, Meta(description="used by nullspace only; kept across switches")]


class GainInUse(Message, frozen=True):
    """The LQR K_h the momentum task applies (Herzog 2016 §3)."""

    configuration: Annotated[list[bool], Meta(description="the contacts it was designed for")]
    blending: Annotated[bool, Meta(description="still moving to it from the last gain")]
    pending: Annotated[bool, Meta(description="a new gain is being designed off the loop")]
    designs: Annotated[int, Meta(description="gains designed so far")]


class MomentumControl(Message, frozen=True):
    """The momentum task's feedback law and the LQR gain in use (null under pd)."""

    mode: Literal["pd", "lqr", "lqr_talos"]
    gain_in_use: GainInUse | None


class MomentumReport(MomentumControl, frozen=True):
    """`info`'s and the `momentum` reply's: K_h (6 x 9) at the current contacts, 4 significant
    digits, null while the stack has no momentum task."""

    gain: list[list[float]] | None


class InternalForce(Message, frozen=True):
    """Kim 2016 §IV: tension between the point feet in support, N, > 0 apart."""

    reference: float
    gain: Annotated[float, Meta(description="K_F")]
    source: Literal["contacts", "torques"]
    sensed: Annotated[list[float], Meta(description="one per pair of feet; empty when idle")]
    command: Annotated[list[float], Meta(description="eq. 12")]


class StatsUs(Message, frozen=True):
    """Percentiles of a duration, µs (an empty object before the loop's first refresh)."""

    p50: float | None = None
    p99: float | None = None
    max: float | None = None


class Floor(Message, frozen=True):
    """The machine's floor: the loop's own on-time fraction with nothing to do, measured at
    start-up and by the `floor` command (lab/runtime/floor.py)."""

    on_time_fraction: float
    ticks: int
    seconds: Annotated[float, Meta(description="s measured")]
    late_wakeups: int
    late_pushed: int
    lateness_us: StatsUs
    tolerance_us: Annotated[float, Meta(description="a tick this late still counts on time")]
    clock_s: Annotated[float, Meta(description="the loop's clock when it ended")]


class Loop(Message, frozen=True):
    """The realtime loop's statistics (added by the sim process; docs/protocol.md)."""

    rate_hz: Annotated[float, Meta(description="scheduled rate")]
    realtime: Annotated[bool, Meta(description="false in --fast mode (no sleeping)")]
    fifo: Annotated[bool, Meta(description="SCHED_FIFO was granted (sched == 'fifo')")]
    sched: Annotated[Literal["fifo", "other"], Meta(description="the loop thread's policy")]
    ticks: Annotated[int, Meta(description="loop iterations since start")]
    on_time_fraction: Annotated[
        float, Meta(description="ticks that started <= 10 % of a period late, since start")
    ]
    lateness_us: Annotated[StatsUs, Meta(description="tick start minus scheduled start")]
    tick_us: Annotated[StatsUs, Meta(description="work per iteration")]
    overruns: Annotated[
        int, Meta(description="iterations whose work ended after the next deadline")
    ]
    late_wakeups: Annotated[
        int, Meta(description="late ticks whose tick before ended in time (woken late)")
    ]
    late_pushed: Annotated[
        int, Meta(description="late ticks pushed late by the tick before's overrun")
    ]
    skipped: Annotated[int, Meta(description="periods dropped after stalls > 50 ms")]
    slice_us: Annotated[
        float | None, Meta(description="EEVDF slice granted at SCHED_OTHER (--slice-ms), or null")
    ]
    nice: Annotated[int | None, Meta(description="nice value granted (--nice), or null")]
    gc_collections: Annotated[
        list[int], Meta(description="Python garbage collections since start, by generation")
    ]
    tick_us_by_kind: Annotated[
        dict[str, StatsUs],
        Meta(description="tick_us by what the loop did beside the tick: plain, telemetry, ..."),
    ]
    late_lateness_us: Annotated[
        dict[str, StatsUs], Meta(description="lateness of late ticks: woken, pushed (overrun)")
    ]
    gc_pause_us: Annotated[dict[str, StatsUs], Meta(description="garbage collection pauses")]
    floor: Annotated[Floor | None, Meta(description="the floor last measured, or null")]
    spin_margin_us: Annotated[float, Meta(description="the wake-up margin spun before a tick")]
    adaptive_spin: Annotated[bool, Meta(description="the margin is learned (--spin-ms auto)")]
    cpu_s: Annotated[float, Meta(description="the loop thread's CPU time")]
    clock_s: Annotated[
        float | None, Meta(description="the loop's monotonic clock when the message was built")
    ] = None


class Recording(Message, frozen=True):
    """A recording of the live session (`record`)."""

    file: str
    seconds: float


class Recorded(Recording, frozen=True):
    """A recording finished (`record` with `stop`)."""

    bytes: int


class Control(Message, frozen=True):
    """The control lock's holder (null: free)."""

    holder: str | None


class HandTarget(Message, frozen=True):
    """One hand's target of the `hands` task (the `hand` reply, `info.hands`)."""

    name: str
    position: Annotated[Vec3, Meta(description="m, in frame; the circle's centre")]
    rpy: Annotated[Vec3, Meta(description="rad, roll-pitch-yaw in frame")]
    radius: Annotated[float, Meta(description="m, 0: still")]
    period: Annotated[float, Meta(description="s, one turn of the circle")]
    frame: Annotated[str, Meta(description="world, or heading: the trunk's position and yaw")] = (
        "world"
    )


class Playback(Message, frozen=True):
    """Where `lab replay --serve`'s playback is."""

    file: str
    t: float
    duration: float
    speed: float
    paused: bool
    ended: bool
    cut_short: str | None = None


# ---------------------------------------------------------------------------------- replies
class Reply(Message, frozen=True):
    """Every reply: `ok`, and `error` (starting with the verb) when not; an `ok` reply carries
    what its verb changed."""

    ok: bool
    error: str | None = None
    superseded: Annotated[bool | None, Meta(description="velocity: a newer one won")] = None
    hierarchy: Hierarchy | None = None
    stack: Stack | None = None
    preset: str | None = None
    task: str | None = None
    kp: float | None = None
    kd: float | None = None
    weight: float | None = None
    internal_force: InternalForce | None = None
    momentum: MomentumReport | None = None
    stance: str | None = None
    swing: float | None = None
    recording: Recording | None = None
    recorded: Recorded | None = None
    control: Control | None = None
    replay: Playback | None = None
    hand: HandTarget | None = None
    floor: Floor | None = None


class TaskGainsEntry(Message, frozen=True):
    """A task's gains in `info`; a gain it does not read is null."""

    name: str
    kp: float | None
    kd: float | None
    weight: float | None
    gains: Annotated[list[Literal["kp", "kd", "weight"]], Meta(description="those it reads")]


class InfoReply(Message, frozen=True):
    """The `info` reply: what the lab offers and what it runs now."""

    ok: bool
    robots: list[str]
    scenes: list[str]
    methods: list[str]
    solvers: list[str]
    formulations: list[str]
    momentum_modes: list[str]
    kernels: list[str]
    gaits: list[str]
    stack_presets: list[str]
    robot: str
    scene: str
    gait: str
    momentum: MomentumReport
    hierarchy: Hierarchy
    kernel: Annotated[str, Meta(description="the kernel asked for (telemetry: which ran)")]
    tick: Annotated[TickPath, Meta(description="the last server tick's path")]
    tick_note: Annotated[str, Meta(description="why the Python path ran ('' when native)")]
    stack: Stack
    known: Annotated[list[str], Meta(description="every task and constraint name")]
    tasks: list[TaskGainsEntry]
    bodies: Annotated[list[str], Meta(description="link names for push")]
    base: Annotated[str, Meta(description="the link of the floating base")]
    mass: Annotated[float, Meta(description="kg")]
    contacts: list[str]
    hands: Annotated[list[HandTarget], Meta(description="each hand's target")]
    paused: bool
    realism: Annotated[
        dict[str, float | int | str],
        Meta(
            description="every realism knob running, the actuator and the preset (docs/realism.md)"
        ),
    ]
    payloads: Annotated[dict[str, float], Meta(description="kg fixed to each link by `payload`")]
    t: float
    limits: dict[str, float] | None = None
    loop: Loop | None = None
    control: Annotated[
        Control | None, Meta(description="added by lab serve: the control lock's holder")
    ] = None


# ---------------------------------------------------------------------------------- telemetry
class Base(Message, frozen=True):
    """Base pose (world) and velocity (world axes)."""

    position: Vec3
    quaternion: QuatXyzw
    linear_velocity: Vec3
    angular_velocity: Vec3


class Com(Message, frozen=True):
    """Centre of mass, m and m/s, world."""

    position: Vec3
    velocity: Vec3


class Momentum(Message, frozen=True):
    """Centroidal momentum about the CoM, world axes."""

    linear: Annotated[Vec3, Meta(description="kg m/s")]
    angular: Annotated[Vec3, Meta(description="kg m^2/s")]


class Contact(Message, frozen=True):
    """One foot, in the description's order."""

    name: str
    kind: Literal["point", "flat"]
    active: Annotated[bool, Meta(description="in the controller's contact set")]
    position: Vec3
    measured_force: Annotated[Vec3, Meta(description="N, world: from MuJoCo")]
    force: Annotated[Vec3, Meta(description="N, world: the controller's solution")]
    moment: Annotated[Vec3, Meta(description="flat feet: N m, world, about the sole")] | None = None


class Cop(Message, frozen=True):
    """Centres of pressure: each flat foot's (null unloaded), and the net one (null in flight)."""

    feet: dict[str, Vec3 | None]
    net: Vec3 | None


class TaskEntry(Message, frozen=True):
    """A name of the stack with its level, tracking error and gains (null: not read)."""

    name: str
    level: Annotated[int, Meta(description="0 = highest priority")]
    error: Annotated[float, Meta(description="norm of the tracking error this tick (0: none)")]
    kp: float | None
    kd: float | None
    weight: float | None


class Prediction(Message, frozen=True):
    """The stepping planner's last answer: rows [t, x, ẋ] every 20 ms."""

    t: float
    foot: list[float]
    forward: list[list[float]]
    lateral: list[list[float]]


class Stepping(Message, frozen=True):
    """biped_step (Kim 2016 §V) only: phase portraits, heading frame."""

    steps: int
    swings_cut: int
    com: Annotated[list[float], Meta(min_length=2, max_length=2)]
    com_velocity: Annotated[list[float], Meta(min_length=2, max_length=2)]
    prediction: Prediction | None


class Ran(Message, frozen=True):
    """What computed the last tick, and why it differs from what was asked ('' if not)."""

    kernel: KernelName
    method: Literal["cascade", "weighted", "nullspace", "wbosc"]
    solver: Annotated[
        Literal["daqp", "clarabel", "none"], Meta(description="none: the method solves no QP")
    ]
    formulation: Annotated[
        Literal["qdd_force", "full", "qdd_tau", "sequential"],
        Meta(description="qdd_force (x = [q̈, F]) for every method but nullspace"),
    ]
    behaviour: Annotated[
        Literal["native", "python", "none"],
        Meta(description="the kernel that ran the behaviour's update (none: it has none)"),
    ]
    note: str
    tick: Annotated[TickPath, Meta(description="the server tick's path: one crossing or Python")]
    tick_note: Annotated[str, Meta(description="why the Python path ran ('' when native)")]
    estimator: Annotated[
        Estimator, Meta(description="what the controller read of the base: true state or EKF")
    ]


class Status(Message, frozen=True):
    """How the last tick went (as TSID's HQPOutput status). fallback: a level's QP failed and
    kept the solution of the levels above; capped: nullspace's active set stopped at its cap;
    violated: wbosc (closed form) found a constraint of the stack violated and sent the torques
    as they are; failed: no solution, fallback torques (joint PD + bias) were applied."""

    status: Literal["ok", "fallback", "capped", "violated", "failed"]
    level: Annotated[int | None, Meta(description="the first level concerned, or null")]
    reason: Annotated[str, Meta(description="why ('' when ok)")]


class ControllerWarning(Message, frozen=True):
    """A Python warning the controller raised in the last 0.5 s of sim time."""

    kind: str
    message: str
    t: float
    ticks: int


class Qp(Message, frozen=True):
    """Controller time of the last tick (µs) and failed ticks since the session started."""

    solve_us: float
    failures: int


class Solution(Message, frozen=True):
    """How the hierarchy found the last tick's x."""

    fallback_levels: Annotated[list[int], Meta(description="stack levels that fell back")]
    levels: Annotated[
        list[Literal["exact", "qp", "kept_above", "no_freedom", "projected"]],
        Meta(description="one status per stack level"),
    ]
    residuals: Annotated[list[float], Meta(description="‖A x − b‖ of each level's equalities")]
    qp_solves: int
    level_us: Annotated[list[float], Meta(description="time spent on each level, µs")]
    violations: Annotated[
        list[str], Meta(description="wbosc: 'level k name: exceeded by x' per violation")
    ]


class VelocityInEffect(Message, frozen=True):
    """The velocity command in effect (after the deadman ramp)."""

    vx: float
    vy: float
    yaw_rate: float


class PushInProgress(Message, frozen=True):
    """An external force being applied now (N, world) at `point` (world), `remaining` s."""

    body: str
    force: Vec3
    point: Vec3
    remaining: float


class Realism(Message, frozen=True):
    """Which realism ran (docs/realism.md; every knob is in info.realism)."""

    preset: Annotated[
        str, Meta(description="ideal, typical, harsh, or custom (knobs set over one)")
    ]
    ideal: Annotated[bool, Meta(description="the layer changed nothing (exact state, torques)")]
    kernel: Annotated[KernelName, Meta(description="where the layer ran: lab._kernel or Python")]
    payloads: Annotated[dict[str, float], Meta(description="kg fixed to each link by `payload`")]


class EstimatorErrors(Message, frozen=True):
    """What the controller read of the base against the truth (docs/realism.md "The state
    estimator"): estimate − truth at the last tick that read through the realism layer; zeros
    when the controller read the true state itself (the native tick)."""

    name: Annotated[Estimator, Meta(description="true: the measured true state; ekf: the EKF")]
    position_error: Annotated[Vec3, Meta(description="base position, world axes, m")]
    velocity_error: Annotated[Vec3, Meta(description="base linear velocity, world axes, m/s")]
    yaw_error: Annotated[float, Meta(description="base yaw, rad, in [-π, π]")]
    orientation_error: Annotated[float, Meta(description="base orientation, whole angle, rad")]


class Telemetry(Message, frozen=True):
    """`lab/<id>/telemetry`: everything the UI plots and the tests check."""

    t: Annotated[
        float,
        Meta(description="sim time, s: 0 after reset or a switch, never backwards otherwise"),
    ]
    robot: str
    scene: str
    paused: bool
    fell: Annotated[bool, Meta(description="fallen: torques off, joints damped until reset")]
    divergences: Annotated[int, Meta(description="sim divergences since the process started")]
    gait: str
    base: Base
    com: Com
    momentum: Momentum
    contacts: list[Contact]
    cop: Cop
    tasks: Annotated[list[TaskEntry] | None, Meta(description="every name in the stack")]
    stack: Stack | None
    momentum_control: MomentumControl | None
    internal_force: InternalForce
    stepping: Annotated[Stepping | None, Meta(description="biped_step only, else null")]
    hierarchy: Annotated[
        Hierarchy | None, Meta(description="what is asked; `ran` says what computed the tick")
    ]
    kernel: Annotated[KernelName, Meta(description="the kernel that ran the last tick")]
    kernel_note: Annotated[
        str | None,
        Meta(description="why the native kernel asked for did not run ('' when it did)"),
    ]
    ran: Ran
    realism: Realism
    estimator: EstimatorErrors
    status: Status
    controller_warnings: list[ControllerWarning]
    qp: Qp
    solution: Annotated[
        Solution | None, Meta(description="null before the first tick and after fallback torques")
    ]
    command: VelocityInEffect
    pushes: list[PushInProgress]
    loop: Annotated[Loop | None, Meta(description="added by the sim process")] = None
    recording: Annotated[
        Recording | None, Meta(description="added by lab serve: the recording running now")
    ] = None
    replay: Annotated[
        Playback | None, Meta(description="added by lab replay --serve: where playback is")
    ] = None
    control: Annotated[
        Control | None, Meta(description="added by lab serve: the control lock's holder")
    ] = None


# ---------------------------------------------------------------------------------- state
class Joints(Message, frozen=True):
    """Actuated joints in pinocchio order (rad or m)."""

    names: list[str]
    positions: list[float]


class Frames(Message, frozen=True):
    """URDF links and contact frames: world placements, same order in each list."""

    names: list[str]
    positions: list[Vec3]
    quaternions: list[QuatXyzw]


class StateBase(Message, frozen=True):
    """The base's world pose."""

    position: Vec3
    quaternion: QuatXyzw


class State(Message, frozen=True):
    """`lab/<id>/state`: what the UI needs to draw the robot."""

    t: float
    robot: Annotated[str, Meta(description="changes after a robot switch: reload the model")]
    base: StateBase
    joints: Joints
    frames: Frames
    scene_bodies: Annotated[
        dict[str, Annotated[list[float], Meta(min_length=7, max_length=7)]] | None,
        Meta(description="moving terrain only: [x, y, z, qw, qx, qy, qz] per body"),
    ] = None


M = TypeVar("M", bound=Message)


def decode(raw: bytes | object, kind: type[M]) -> M:
    """A message of type `kind` from its JSON bytes or decoded object; raises
    msgspec.ValidationError (or DecodeError) saying what does not fit."""
    if isinstance(raw, bytes):
        return msgspec.json.decode(raw, type=kind)
    return msgspec.convert(raw, kind)
