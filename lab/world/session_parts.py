"""What a session is built from and what it builds: `SessionConfig` (robot, scene, the
controller's initial choices, realism) and `SessionParts` (robot, plant, model, controller, the
native tick, the realism layer), made by `build_parts` on any thread (lab/runtime/switch.py builds
a switch's parts beside the loop) and swapped into a running session by `Session.install`.
"""

from collections.abc import Callable
from dataclasses import dataclass, field, replace

from lab.controller.behaviours import Balance, Behaviour
from lab.controller.constraints import ContactLimits
from lab.controller.controller import ControllerConfig
from lab.controller.hand_targets import HandTargets
from lab.controller.model import RobotModel
from lab.controller.native import NativeController
from lab.controller.stack import Stack
from lab.description import robot_names
from lab.protocol import TaskGains
from lab.realism.knobs import RealismKnobs
from lab.realism.layer import NativeRealismLayer, RealismLayer, realism_layer
from lab.realism.model_error import perturbed_model
from lab.robot import FramePlacements, Robot
from lab.scenes import SCENE_ROBOTS, SCENES
from lab.world.compiled import CompiledWorld, WorldKey, compile_world, world_key
from lab.world.estimator import BaseEstimator
from lab.world.native_tick import NativeTick
from lab.world.plant import MujocoPlant


@dataclass
class SessionConfig:
    """What a session is built from: robot, scene, and the controller's initial choices (None =
    the robot's default). Commands change the controller's own `ControllerConfig`, the one
    source of truth while the session runs; a rebuild reads it back (`Session._live_config`)."""

    robot: str = "anymal"
    scene: str = "flat"
    method: str = "cascade"  # hierarchy method: cascade | weighted | nullspace
    solver: str = "daqp"
    formulation: str = "qdd_force"  # `nullspace` only: its optimization vector (Hutter 2014 §4)
    stack: list[list[str]] | None = None
    gains: dict[str, dict[str, float]] = field(default_factory=dict)
    timestep: float = 1e-3
    kernel: str | None = None  # native | python; None: the robot's, else native when built
    terrain_seed: int | None = None  # of a scene with random terrain (rough); None: its own
    # sensors, delays, actuators, drive limits and model error (lab/realism); default ideal
    realism: RealismKnobs = field(default_factory=RealismKnobs)


@dataclass(eq=False, repr=False)
class SessionParts:
    """What a robot and scene make of a session: built by `build_parts` (on any thread: it
    touches no running session), swapped in by `Session.install`. A session is its parts and
    the state of its run around them: `SessionBase` derives from this class, so the parts are
    declared here alone."""

    config: SessionConfig
    robot: Robot
    plant: MujocoPlant
    model: RobotModel
    controller: NativeController
    frame_placements: FramePlacements
    native_tick: NativeTick
    realism: RealismLayer | NativeRealismLayer
    estimator: BaseEstimator  # the base state the controller reads: truth, or the EKF's
    behaviour: Behaviour  # standing (Balance) until the `gait` command starts another
    hands: HandTargets  # the hands task's targets (a `hand` command moves them)

    def stand(self, time: float = 0.0) -> None:
        """The robot standing at rest at sim time `time` (s), as a session starts: the plant
        reset there without extra damping, the realism layer and the estimator started from it,
        the controller's last solution forgotten, each hand held where it stands. A session's
        reset does it on the loop; `build_parts` does it to new parts, on the switch's thread,
        so that the swap (`Session.install`) need not (0.6 ms of its 0.9, docs/reliability.md)."""
        q = self.robot.q_standing
        self.plant.reset(q, time=time)
        self.plant.set_joint_damping(0.0)
        self.realism.reset(q)
        self.estimator.reset(*self.plant.state())
        self.controller.forget_last_solution()
        self.hands = HandTargets.holding(self.robot.model, q, self.robot.description.hands)


def build_parts(
    config: SessionConfig, world: Callable[[WorldKey], CompiledWorld] = compile_world
) -> SessionParts:
    """Plant, model and controller for `config`; raises KeyError or ValueError on bad names.
    `world` makes the robot and MuJoCo's model (lab/world/compiled.py): at once by default,
    or in a worker process with a cache (lab/runtime/world_cache.py)."""
    if config.robot not in (known := robot_names()):
        raise KeyError(f"unknown robot {config.robot!r} (robots: {', '.join(known)})")
    if config.scene not in SCENES:
        raise KeyError(f"unknown scene {config.scene!r} (scenes: {', '.join(SCENES)})")
    made_for = SCENE_ROBOTS.get(config.scene, (config.robot,))
    if config.robot not in made_for:
        raise ValueError(
            f"scene {config.scene!r} is made for robot {', '.join(made_for)} only, "
            f"not {config.robot!r}"
        )
    compiled = world(world_key(config.robot, config.scene, config.timestep, config.terrain_seed))
    robot, description = compiled.robot, compiled.robot.description
    plant = MujocoPlant(
        robot, config.scene, config.timestep, config.terrain_seed, mj_model=compiled.mj_model
    )
    knobs = config.realism
    plant.set_drive_limits(knobs.torque_saturation, knobs.coulomb_friction, knobs.viscous_friction)
    # the controller's model: the simulator's, or a copy with model error (lab/realism)
    model = RobotModel(perturbed_model(robot.model, *knobs.model_error), robot.contacts)
    gains = dict(description.gains)
    for name, overrides in config.gains.items():
        gains[name] = replace(gains.get(name, TaskGains()), **overrides)
    # the state a session starts from (the plant stands at rest): the swap takes this Balance
    model.update(*plant.state())
    standing = Balance(model, robot.q_standing)
    controller = NativeController(
        model,
        standing.references,
        ControllerConfig(
            stack=Stack.of(config.stack or description.stack),
            gains=gains,
            method=config.method,
            solver=config.solver,
            formulation=config.formulation,
            limits=ContactLimits(friction=description.friction),
            kernel=config.kernel or description.kernel or "native",
        ),
        robot.torque_limits,
        # the same model's serialization, made once per robot, unless model error changed it
        robot.serialized_model if knobs.model_error[:2] == (0.0, 0.0) else None,
    )
    controller.set_hands(tuple(frame for _, frame in description.hands), description.hand_joints)
    native_tick = NativeTick(plant, controller)
    layer = realism_layer(knobs, model.na, config.timestep)
    placements = FramePlacements(robot)
    estimator = BaseEstimator(knobs, robot, config.timestep)
    parts = SessionParts(
        config, robot, plant, model, controller, placements, native_tick, layer, estimator,
        standing, hands=HandTargets((), []),  # `stand` holds each hand where it stands
    )  # fmt: skip
    parts.stand()  # as the session's reset does: the swap takes them standing (`install`)
    return parts
