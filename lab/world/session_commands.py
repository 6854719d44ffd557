"""The session's commands: `handle` validates a (verb, payload) into its lab.protocol struct
(`parse_command`), `execute` applies one between ticks (`_apply`: one case per struct) and
answers `{"ok": true, ...}` or refuses it naming the problem (`refuse`: a rejected command changes
nothing); the `info` reply.
"""

from dataclasses import replace
from typing import assert_never

import numpy as np

from lab import protocol as cmd
from lab.controller.behaviours import BEHAVIOURS
from lab.controller.behaviours.stance import Stance
from lab.controller.hierarchy import METHODS
from lab.controller.hierarchy.formulations import FORMULATIONS
from lab.controller.momentum import MOMENTUM_MODES
from lab.controller.native import KERNELS
from lab.controller.qp import SOLVERS
from lab.controller.stack import Stack, StackError
from lab.description import ROBOT_NAMES
from lab.realism.knobs import knobs_from, preset
from lab.realism.layer import realism_layer
from lab.scenes import SCENES
from lab.scenes.setups import SCENE_SETUPS
from lab.stack_presets import PRESET_NAMES
from lab.world.estimator import BaseEstimator
from lab.world.memory import release_free_memory
from lab.world.session_base import Push
from lab.world.session_parts import build_parts
from lab.world.session_tick import SessionTick
from lab.world.telemetry import (
    hierarchy_report,
    internal_force_report,
    momentum_gain_report,
    momentum_report,
    task_gains_report,
)


class SessionCommands(SessionTick):
    """A session that takes commands (module docstring)."""

    def handle(self, verb: str, payload: object = None) -> dict:
        """Validate and apply one command; never raises. Rejected commands change nothing."""
        try:
            command = cmd.parse_command(verb, {} if payload is None else payload)
        except cmd.CommandError as error:
            return self.refuse(verb, str(error))
        return self.execute(verb, command)

    def execute(self, verb: str, command: cmd.Command) -> dict:
        """Apply one command already validated by `parse_command` (the sim process validates
        off the loop: lab/runtime/intake.py); never raises. What the session refuses (an
        unknown name, a stack it cannot run) changes nothing."""
        self._plan = None  # the next tick decides its path again (session_tick.py's TickPlan)
        try:
            reply = self._apply(command)
        except (cmd.CommandError, StackError, KeyError, ValueError) as error:
            message = error.args[0] if isinstance(error, KeyError) and error.args else str(error)
            return self.refuse(verb, str(message))
        return {"ok": True, **reply}

    def refuse(self, verb: str, message: str) -> dict:
        """The reply refusing a command (`message` says why), reported as `rejected_command`;
        every error reply starts with the verb (a name the session does not know, ...)."""
        if not message.startswith(f"{verb}:"):
            message = f"{verb[:64]}: {message}"
        self._event("rejected_command", message, verb=verb[:64], error=message)
        return {"ok": False, "error": message}

    def _apply(self, command: cmd.Command) -> dict:
        """Apply `command`: one case per command struct (lab.protocol.commands)."""
        match command:
            case cmd.InfoCommand():
                return self.info()
            case cmd.VelocityCommand(vx=vx, vy=vy, yaw_rate=yaw_rate):
                self.velocity = np.array([vx, vy, yaw_rate])
                return {}
            case cmd.PushCommand(body=body, force=force, duration=duration, point=point):
                self._push(
                    body, np.array(force), duration, None if point is None else np.array(point)
                )
                return {}
            case cmd.RobotCommand() | cmd.SceneCommand():
                setup = self.setup_commands(command)  # refused before anything changes
                old = self.install(build_parts(self.switch_config(command)))
                del old  # the old session's parts, freed here...
                release_free_memory()  # ...and the heap they took given back (memory.py)
                return self.use_setup(setup)
            case cmd.HierarchyCommand(
                method=method, solver=solver, formulation=formulation, kernel=kernel
            ):
                if kernel is not None and kernel not in KERNELS:  # a rejection changes nothing
                    raise KeyError(f"unknown kernel {kernel!r} (kernels: {', '.join(KERNELS)})")
                method = method or self.controller.config.method
                self.controller.set_hierarchy(method, solver, formulation)
                self.controller.set_kernel(kernel or self.controller.config.kernel)
                return {"hierarchy": hierarchy_report(self.controller)}
            case cmd.StackCommand(preset=str(preset)):
                return self._use_preset(preset)
            case cmd.StackCommand(levels=levels):
                stack = Stack.of(levels)
                self.controller.set_stack(stack)
                return {"stack": stack.as_lists()}
            case cmd.GainsCommand(task=task, kp=kp, kd=kd, weight=weight):
                gains = self.controller.set_gains(task, kp, kd, weight)
                return {"task": task, "kp": gains.kp, "kd": gains.kd, "weight": gains.weight}
            case cmd.FloorCommand():
                raise cmd.CommandError("floor: this session has no realtime loop (`lab serve`)")
            case cmd.RecordCommand():
                raise cmd.CommandError(
                    "record: this session has no recorder (`lab serve` records; `lab run` takes "
                    "--record FILE)"
                )
            case cmd.ResetCommand():
                restored = self._standing_stack()
                self._reset_state()
                note = f"; {restored}" if restored else ""
                self._event("reset", f"reset to the standing posture{note}")
                return {"stack": self.controller.config.stack.as_lists()} if restored else {}
            case cmd.PauseCommand():
                self.paused = True
                return {}
            case cmd.ResumeCommand():
                self.paused = False
                return {}
            case cmd.GaitCommand(name=name) as gait:
                return self._set_behaviour(name, gait.options())
            case cmd.InternalForceCommand(reference=reference, source=source):
                internal = self.controller.internal_force
                if source is not None:
                    internal.set_source(source)  # ValueError names the sources, changes nothing
                if reference is not None:
                    internal.reference = reference
                return {"internal_force": internal_force_report(self.controller)}
            case cmd.MomentumCommand(mode=mode):
                self.controller.set_momentum_mode(mode)  # ValueError names the modes
                gain = momentum_gain_report(self.controller)
                return {"momentum": {**momentum_report(self.controller), "gain": gain}}
            case cmd.StanceCommand(side=side, swing=swing):
                return self._stance(side, swing)
            case cmd.HandCommand() as hand:
                return {"hand": self.hands.command(hand, self.time)}  # KeyError names the hands
            case cmd.RealismCommand(preset=name) as realism:
                return self._set_realism(name, realism.knobs())
            case cmd.PayloadCommand(body=body, mass=mass, offset=offset):
                self.plant.set_payload(body, mass, np.array(offset))  # KeyError names bodies
                return {"payloads": dict(self.plant.payloads)}
            case cmd.TakeCommand() | cmd.ReleaseCommand():  # one user: nothing to lock
                return {}
            case _:  # a command struct without a case here: mypy names it
                assert_never(command)

    def _set_realism(self, name: str | None, values: dict) -> dict:
        """Run realism preset `name` (None: the knobs running now) with `values` over it. A
        new model error rebuilds the session's parts (the robot stands again); other knobs
        replace the realism layer and the drive limits at once. Raises ValueError naming a bad
        knob, changing nothing."""
        knobs = knobs_from(preset(name, self.config.robot) if name else self.realism.knobs, values)
        if knobs.model_error != self.realism.knobs.model_error:
            old = self.install(build_parts(replace(self._live_config(), realism=knobs)))
            del old
        else:
            touch_changed = knobs.contact_estimate != self.realism.knobs.contact_estimate
            self.realism = realism_layer(knobs, self.model.na, self.config.timestep)
            self.plant.set_drive_limits(
                knobs.torque_saturation, knobs.coulomb_friction, knobs.viscous_friction
            )
            self.realism.reset(self._true_state[0], self.tau)
            self.estimator = BaseEstimator(knobs, self.robot, self.config.timestep)
            self.estimator.reset(*self.plant.state())  # the filter starts at the truth
            if touch_changed:
                self._start_touch_estimate()
        return {"realism": self.realism.knobs.values()}

    def _stance(self, side: str | None, swing: float | None = None) -> dict:
        """Stand on both soles or on `side` (Herzog §5.4, behaviours/stance.py; None: where it
        stands), swinging the lifted leg at `swing` Hz if given; starts the stance behaviour,
        with the robot's `stance_stack` preset (Herzog's Table 4, or its variant for free arms)
        if the stack has no `swing_sole` (or no `swing_leg` for a swing).
        Raises ValueError for a robot without two flat soles or an unknown side, changing
        nothing."""
        contacts = self.model.contacts
        if len(contacts) != 2 or any(contact.kind != "flat" for contact in contacts):
            raise ValueError(f"stance: robot {self.config.robot!r} is not a biped with flat soles")
        reply: dict = {}
        if isinstance(self.behaviour, Stance):
            stance = self.behaviour
            if side is not None:
                stance.request(side)
        else:
            self.model.update(*self.plant.state())
            stance = Stance(self.model, self.robot.q_standing)
            if side is not None:
                stance.request(side)  # raises before anything changes
            self.behaviour = stance
            self.controller.references = stance.references
        if swing is not None:
            stance.swing(swing)
        names = self.controller.config.stack.names()
        if "swing_sole" not in names or (stance.swing_hz and "swing_leg" not in names):
            reply = self._use_preset(self.robot.description.stance_stack)
        return {"stance": side or stance.stance, "swing": stance.swing_hz, **reply}

    def _standing_stack(self) -> str:
        """Before a reset to standing: a stack that a walking gait brought along (and nobody
        edited since) gives way to the robot's default stack, gains and the session's method,
        which stand (Bolt fell 1.4 s after every Reset under biped_step's kim_stepping: no CoM
        task). What was done, or "" when the stack stays."""
        stack = self.controller.config.stack.as_lists()
        if self._gait_stack is None or stack != self._gait_stack:
            return ""
        description = self.robot.description
        self.controller.set_stack(Stack.of(description.stack))
        for task, gains in description.gains.items():
            self.controller.set_gains(task, gains.kp, gains.kd, gains.weight)
        self.controller.set_hierarchy(self.config.method)
        self._gait_stack = None
        return "the walking stack gave way to the robot's default stack, which stands"

    def _push(
        self, body: str, force: np.ndarray, duration: float, point: np.ndarray | None
    ) -> None:
        self.plant.push(body, force, point)  # raises KeyError naming the known bodies
        self.pushes[body] = Push(body, force, point, self.time + duration)

    def setup_commands(self, command: object) -> list[cmd.Command]:
        """The commands of the set-up a command asks for (none but a `scene` with `setup`): the
        one the scene was made for (lab/scenes/setups.py), for the robot running, which a
        scene switch keeps. KeyError naming what is missing when the scene has none for it."""
        if not isinstance(command, cmd.SceneCommand) or not command.setup:
            return []
        made = SCENE_SETUPS.get(command.name)
        if made is None or self.config.robot not in made.robots:
            offered = [scene for scene, s in SCENE_SETUPS.items() if self.config.robot in s.robots]
            raise KeyError(
                f"scene {command.name!r} has no set-up for {self.config.robot} (scenes with "
                f"one for it: {', '.join(offered) or 'none'})"
            )
        return [cmd.parse_command(v, p) for v, p in made.commands(self.model.mass)]

    def use_setup(self, commands: list[cmd.Command]) -> dict:
        """Apply a scene's set-up (`setup_commands`) right after its switch, before the new
        scene's first tick, so that the robot never runs there without it; the reply's fields:
        `setup`, the verbs applied, and a `note` naming a command refused (its event is shown)."""
        if not commands:
            return {}
        applied: list[str] = []
        for command in commands:
            reply = self.execute(command.VERB, command)
            if not reply["ok"]:
                return {"setup": applied, "note": f"the set-up stopped: {reply['error']}"}
            applied.append(command.VERB)
        return {"setup": applied}

    def info(self) -> dict:
        return {
            "robots": list(ROBOT_NAMES),
            "scenes": list(SCENES),
            "methods": list(METHODS),
            "solvers": list(SOLVERS),
            "formulations": list(FORMULATIONS),
            "momentum_modes": list(MOMENTUM_MODES),
            "kernels": list(KERNELS),
            "gaits": list(BEHAVIOURS),
            "stack_presets": list(PRESET_NAMES),
            "robot": self.config.robot,
            "scene": self.config.scene,
            "gait": self.behaviour.name,
            "momentum": {
                **momentum_report(self.controller),
                "gain": momentum_gain_report(self.controller),
            },
            "hierarchy": hierarchy_report(self.controller),
            "kernel": self.controller.config.kernel,
            **self.tick_report(),
            "stack": self.controller.config.stack.as_lists(),
            "known": list(self.controller.known_names),
            "tasks": task_gains_report(self.controller),
            "bodies": list(self.plant.body_names),
            "base": self.robot.base_link,
            "mass": self.model.mass,
            "contacts": [c.name for c in self.robot.contacts],
            "hands": self.hands.report(),
            "paused": self.paused,
            "realism": self.realism.knobs.values(),
            "payloads": dict(self.plant.payloads),
            "t": self.time,
        }
