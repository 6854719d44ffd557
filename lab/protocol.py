"""The lab protocol's names and plain records (docs/protocol.md), defined once.

The sim process, `lab.client`, `lab teleop` and the browser UI all import this module; it holds
only the standard library, so a client process stays light (no pinocchio, no MuJoCo). What is
here: the Zenoh key expressions of a lab (`LabKeys`, scoped by its lab id), the command ranges,
one frozen dataclass per command verb (the payload's shape; `lab.server.commands` validates a
JSON payload into one), and the records a payload or a robot description carries: `ContactSpec`
and `TaskGains`.
"""

import re
import socket
from dataclasses import dataclass
from typing import Literal

# ---------------------------------------------------------------------------------- transport
DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
# Of one command's JSON payload. The largest valid command (a stack of 64 task names of 128
# characters) is under 10 KiB; the cap is checked before a payload is read (issue 25).
MAX_PAYLOAD_BYTES = 16 * 1024
# A client's id: the attachment of each of its command queries (docs/protocol.md, "Clients").
CLIENT_ID_PATTERN = re.compile(r"[A-Za-z0-9_.-]{1,64}")

# ---------------------------------------------------------------------------------- key expressions
# Every key of a sim process is scoped by its lab id, `lab/<id>/...`, so several labs share one
# Zenoh network (a router) without hearing each other's commands. A lab id is one key chunk.
LAB_ID_PATTERN = re.compile(r"[A-Za-z0-9_.-]{1,64}")
# Liveliness tokens of every lab: a client lists the labs it can see by this key expression.
ALL_LABS_ALIVE = "lab/*/alive"


class LabIdError(ValueError):
    """A lab id that cannot be a key chunk (empty, too long, or with `/`, `*`, `$`, ...)."""


@dataclass(frozen=True)
class LabKeys:
    """The key expressions of the lab `lab_id` (docs/protocol.md, "Key expressions")."""

    lab_id: str

    def __post_init__(self) -> None:
        if not LAB_ID_PATTERN.fullmatch(self.lab_id):
            raise LabIdError(
                f"lab id {self.lab_id!r}: 1-64 characters of letters, digits, '_', '.', '-'"
            )

    @property
    def root(self) -> str:
        return f"lab/{self.lab_id}"

    @property
    def cmd_prefix(self) -> str:
        """A command is a query on `cmd_prefix + verb`."""
        return f"{self.root}/cmd/"

    def cmd(self, verb: str) -> str:
        return self.cmd_prefix + verb

    @property
    def telemetry(self) -> str:
        return f"{self.root}/telemetry"

    @property
    def state(self) -> str:
        return f"{self.root}/state"

    @property
    def events(self) -> str:
        return f"{self.root}/events"

    def client(self, client_id: str) -> str:
        """The liveliness token a client holds while its link to the lab is up: the control
        lock is released when its holder's token vanishes (docs/protocol.md)."""
        return f"{self.root}/clients/{client_id}"

    @property
    def clients(self) -> str:
        """Every client's liveliness token (`client`)."""
        return f"{self.root}/clients/*"

    @property
    def alive(self) -> str:
        """A liveliness token the sim process holds while it runs: clients see it appear and
        vanish (Zenoh removes it when the process dies or the link to it breaks), which is how
        they say "disconnected"."""
        return f"{self.root}/alive"


def lab_id_of(key: str) -> str | None:
    """The lab id of a key `lab/<id>/...`; None for any other key."""
    parts = key.split("/")
    if len(parts) < 3 or parts[0] != "lab" or not LAB_ID_PATTERN.fullmatch(parts[1]):
        return None
    return parts[1]


def default_lab_id(robot: str, host: str | None = None) -> str:
    """`<host>-<robot>`, characters a key chunk cannot hold replaced by '-': the id of a sim
    process started without `--lab-id` (host: this machine's name)."""
    host = socket.gethostname() if host is None else host
    return re.sub(r"[^A-Za-z0-9_.-]", "-", f"{host}-{robot}")[:64]


# ---------------------------------------------------------------------------------- command ranges
VX_MAX = 2.0  # m/s, |vx|
VY_MAX = 1.0  # m/s, |vy|
YAW_RATE_MAX = 2.0  # rad/s, |yaw_rate|
PUSH_FORCE_MAX = 2000.0  # N, Euclidean norm of the push force
PUSH_DURATION_MAX = 5.0  # s, 0 < duration <= max
POINT_COORD_MAX = 1000.0  # m, |x|, |y|, |z| of a push application point (world)
GAIN_MAX = 1e5  # 0 <= kp, kd <= max
WEIGHT_MAX = 1e8  # 0 < weight <= max
NAME_MAX_LEN = 128  # characters in a robot / scene / task / link / method / gait name
STACK_MAX_LEVELS = 16
STACK_MAX_TASKS = 64  # task names over all levels
STEP_HEIGHT_MAX = 0.5  # m, 0 < step_height <= max (the behaviour checks it against the legs)
CYCLE_TIME_MAX = 5.0  # s, 0 < cycle_time <= max
SWING_HZ_MAX = 1.0  # Hz, 0 <= stance swing <= max (Herzog's leg swing: 0.25 Hz)

LIMITS: dict[str, float] = {
    "vx": VX_MAX,
    "vy": VY_MAX,
    "yaw_rate": YAW_RATE_MAX,
    "push_force": PUSH_FORCE_MAX,
    "push_duration": PUSH_DURATION_MAX,
    "gain": GAIN_MAX,
    "weight": WEIGHT_MAX,
}  # reported by `info` so clients can size sliders


# ---------------------------------------------------------------------------------- records
ContactKind = Literal["point", "flat"]


@dataclass(frozen=True)
class ContactSpec:
    """One foot.

    A point foot transmits a 3-D force at `frame` (the centre of the foot sphere); a flat foot
    transmits a 6-D wrench at `frame` (the centre of the sole, z along the sole normal), expressed
    in that frame, whose centre of pressure must stay inside the sole rectangle
    `[-half_length, half_length] x [-half_width, half_width]` (m).
    """

    name: str
    frame: str
    kind: ContactKind = "point"
    radius: float = 0.0
    half_length: float = 0.0
    half_width: float = 0.0

    @property
    def force_dim(self) -> int:
        """Rows of the contact's force in x = [q̈, F]: 3 (point) or 6 (flat)."""
        return 3 if self.kind == "point" else 6


@dataclass(frozen=True)
class TaskGains:
    """PD gains (kp in 1/s², kd in 1/s for motion tasks) and the weight of a task inside its
    level (unused fields keep their defaults)."""

    kp: float = 0.0
    kd: float = 0.0
    weight: float = 1.0


# ---------------------------------------------------------------------------------- commands
@dataclass(frozen=True)
class InfoCommand:
    """Ask for robots, scenes, hierarchy methods, solvers, the current stack with gains, state."""


@dataclass(frozen=True)
class VelocityCommand:
    """Desired base velocity in the heading frame: vx forward, vy left (m/s), yaw_rate (rad/s)."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0

    def payload(self) -> dict[str, float]:
        """The `velocity` command's JSON payload."""
        return {"vx": self.vx, "vy": self.vy, "yaw_rate": self.yaw_rate}

    @property
    def is_zero(self) -> bool:
        return self.vx == 0.0 and self.vy == 0.0 and self.yaw_rate == 0.0


@dataclass(frozen=True)
class PushCommand:
    """External force (N, world frame) on a link for `duration` seconds, at `point` (world) or
    at the link origin when `point` is None."""

    body: str
    force: tuple[float, float, float]
    duration: float
    point: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class RobotCommand:
    """Switch robot: rebuilds the session."""

    name: str


@dataclass(frozen=True)
class SceneCommand:
    """Switch scene: rebuilds the session."""

    name: str


@dataclass(frozen=True)
class HierarchyCommand:
    """Switch hierarchy method (and QP solver, `nullspace` formulation, kernel when given);
    a kernel alone keeps the method."""

    method: str | None = None
    solver: str | None = None
    formulation: str | None = None
    kernel: str | None = None


@dataclass(frozen=True)
class StackCommand:
    """New task priority order: levels[0] is the highest priority. Or, with `preset`, a named
    stack from stacks/ (its levels, gains and hierarchy method)."""

    levels: tuple[tuple[str, ...], ...] = ()
    preset: str | None = None


@dataclass(frozen=True)
class GainsCommand:
    """Change a task's PD gains and/or weight; fields left None are unchanged."""

    task: str
    kp: float | None = None
    kd: float | None = None
    weight: float | None = None


@dataclass(frozen=True)
class MomentumCommand:
    """Choose the momentum task's feedback law: `pd` (Herzog eq. 22) or `lqr` (eqs. 23–26)."""

    mode: str


@dataclass(frozen=True)
class InternalForceCommand:
    """Set the internal force between point feet (Kim 2016 §IV): its reference F_int,ref (N,
    > 0 pushing the feet apart) and where the sensed value comes from (`contacts` or `torques`);
    None keeps the current one. The feedback gain K_F is the `internal_force` task's kp."""

    reference: float | None = None
    source: str | None = None


@dataclass(frozen=True)
class StanceCommand:
    """Stand on both soles or lift one (Herzog 2016 §5.4): `double`, `left` or `right` (a biped
    with flat feet; the stance sole is the one named). `swing` (Hz, None: unchanged) swings the
    lifted leg's hip and knee in single support, 0 stops it. Either may be left out (None)."""

    side: str | None = None
    swing: float | None = None


@dataclass(frozen=True)
class ResetCommand:
    """Put the robot back at its standing posture and clear pushes and velocity commands."""


@dataclass(frozen=True)
class PauseCommand:
    """Stop advancing simulated time (the loop keeps running and publishing)."""


@dataclass(frozen=True)
class ResumeCommand:
    """Advance simulated time again after a pause."""


@dataclass(frozen=True)
class GaitCommand:
    """Switch behaviour / gait (e.g. stand, trot, crawl); a walking gait also takes its step
    height (m), cycle time (s) and foothold planner (None = keep or default)."""

    name: str
    step_height: float | None = None
    cycle_time: float | None = None
    footholds: str | None = None


RECORD_ACTIONS = ("start", "stop")


@dataclass(frozen=True)
class RecordCommand:
    """Start or stop recording the live session to an MCAP file (`lab serve` picks the file,
    in its recording directory, and names it in the reply)."""

    action: str


FLOOR_SECONDS_MIN, FLOOR_SECONDS_MAX = 0.5, 10.0  # s, the `floor` command's range


@dataclass(frozen=True)
class FloorCommand:
    """Measure the machine's floor: the loop's on-time fraction with nothing to do, for
    `seconds` (the session stands still meanwhile; lab/server/floor.py). The reply carries it."""

    seconds: float = 2.0


@dataclass(frozen=True)
class TakeCommand:
    """Take the control lock (docs/protocol.md, "The control lock"): refused while another
    client holds it."""


@dataclass(frozen=True)
class ReleaseCommand:
    """Release the control lock this client holds."""


# Verbs any client may send while another holds the control lock: they change nothing in the
# world (a recording watches it).
READ_ONLY_VERBS = ("info", "record", "take", "release")

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
    | TakeCommand
    | ReleaseCommand
    | FloorCommand
)
