"""The compiled world of a session: its robot's pinocchio model and MuJoCo's compiled model.

What a robot and a scene make before any session state exists, from a `WorldKey` alone: the
robot built from its URDF (lab/robot.py; one foot raised where the scene starts it on a block)
and MuJoCo's model compiled from the spec `build_spec` makes of it and the scene. It is most of
a switch's work and pickles, so a switch can build it in a worker process and keep it per key
(lab/runtime/world_cache.py, opt-in); otherwise `compile_world` builds it in-process. The
world is the same either way (tests/runtime/test_switch.py).
"""

import contextlib
import copy
import functools
from collections import OrderedDict
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Generic, TypeVar

import mujoco
import numpy as np

from lab.description import ROBOTS_DIR, load_description
from lab.robot import Robot, build_robot, with_raised_contact
from lab.scenes import START_RISE
from lab.world.plant import _plant
from lab.world.plant_model import build_spec

MJB_NAME = "world.mjb"  # the virtual file a pickled world's MjModel is loaded from
Kept = TypeVar("Kept")
MAX_KEPT = 8  # worlds `KeptWorlds` keeps (Solo12's: 7.4 MB of MuJoCo model, most of it meshes)


@dataclass(frozen=True)
class WorldKey:
    """What a compiled world is made of; `robot_file_ns` is the modification time of
    robots/<robot>.toml (ns), so that a robot file edited meanwhile is read again."""

    robot: str
    scene: str
    timestep: float
    terrain_seed: int | None
    robot_file_ns: int = 0


def world_key(robot: str, scene: str, timestep: float, terrain_seed: int | None) -> WorldKey:
    """The key of a world (the robot file's time read now; 0 for a robot without a file)."""
    path = ROBOTS_DIR / f"{robot}.toml"
    stamp = path.stat().st_mtime_ns if path.is_file() else 0
    return WorldKey(robot, scene, timestep, terrain_seed, stamp)


@dataclass(frozen=True)
class CompiledWorld:
    """The robot (pinocchio) and MuJoCo's compiled model of one `WorldKey`. The plant changes
    its MjModel (lab/world/plant.py): each plant needs a world of its own (a cached one is
    unpickled afresh).

    It pickles its MjModel as MuJoCo's binary model, saved with `mj_saveModel` and loaded from
    a virtual file: both release the GIL. MuJoCo's own pickle of an MjModel keeps it (Solo12's
    7.4 MB of meshes: 20 ms of CPU to load, 60-200 ms of wall time on a busy machine)."""

    robot: Robot
    mj_model: mujoco.MjModel

    def __reduce__(self) -> tuple:
        model = self.mj_model
        mjb = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
        mujoco.mj_saveModel(model, None, mjb)
        return (_loaded_world, (self.robot, mjb.tobytes()))


def _loaded_world(robot: Robot, mjb: bytes) -> CompiledWorld:
    """A pickled `CompiledWorld` again (its MjModel from MuJoCo's binary model)."""
    return CompiledWorld(robot, mujoco.MjModel.from_binary_path(MJB_NAME, {MJB_NAME: mjb}))


def copied_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of `model` (`mj_copyModel`): made without the GIL by `lab._plant` when it is
    built (cpp/plant/plant.cpp, which says who frees it), else by MuJoCo's binding
    (`copy.copy`), which keeps the GIL meanwhile (Solo12's 7.4 MB: 1.3 ms of CPU and its page
    faults, a switch back's longest hold of the loop: docs/reliability.md)."""
    return copy.copy(model) if _plant is None else _plant.copy_model(model)


def compile_world(
    key: WorldKey,
    compiling: Callable[[], AbstractContextManager[object]] = contextlib.nullcontext,
) -> CompiledWorld:
    """Build the robot and compile MuJoCo's model of `key`; raises KeyError or ValueError on a
    robot file or URDF it cannot use (naming what). MuJoCo's compile runs inside `compiling()`
    (a switch's thread gives up its realtime priority for it: lab/runtime/switch.py)."""
    robot = build_robot(load_description(key.robot))
    if key.scene in START_RISE:  # one foot starts on a block
        robot = with_raised_contact(robot, *START_RISE[key.scene])
    spec = build_spec(robot, key.scene, key.timestep, key.terrain_seed)
    with compiling():  # it releases the GIL, and processes meshes on threads of its own
        return CompiledWorld(robot, spec.compile())


class RecentWorlds(Generic[Kept]):
    """What is kept per world key, the last `max_worlds` used (the least recently used goes
    first), with how many were made and how many served from what was kept: the store of
    `KeptWorlds` here and of the worker's `WorldCache` (lab/runtime/world_cache.py)."""

    def __init__(self, max_worlds: int) -> None:
        self.max_worlds = max_worlds
        self._worlds: OrderedDict[WorldKey, Kept] = OrderedDict()
        self.built = 0  # worlds made (not found kept)
        self.hits = 0  # worlds served from what was kept

    def kept_or_made(self, key: WorldKey, make: Callable[[WorldKey], Kept]) -> Kept:
        """What is kept for `key`, else `make(key)`, kept (its exceptions raised here)."""
        kept = self._worlds.get(key)
        if kept is None:
            kept = make(key)
            self.built += 1
            self._worlds[key] = kept
            while len(self._worlds) > self.max_worlds:
                self._worlds.popitem(last=False)
        else:
            self.hits += 1
            self._worlds.move_to_end(key)
        return kept


class KeptWorlds(RecentWorlds[CompiledWorld]):
    """Worlds compiled in this process and kept per key, the last `max_worlds`, for switches
    built on a thread beside the loop (lab/runtime/switch.py): a switch back to a robot and
    scene shares the robot (a `Robot` is never changed: the controller's model is a copy,
    lab/realism/model_error.py) and copies MuJoCo's model as compiled (`copied_model`: without
    the GIL; loading it from its binary took 14-20 ms) instead of parsing the URDF again
    (pinocchio's parser keeps the GIL: 2-16 ms of CPU) and compiling. Used by one thread at a
    time; a world compiled here compiles inside `compiling()` (`compile_world`). `copy` makes
    each copy (benchmarks/bench_switch.py `--copy binding` sets MuJoCo's binding's, `copy.copy`,
    which keeps the GIL)."""

    def __init__(
        self,
        max_worlds: int = MAX_KEPT,
        compiling: Callable[[], AbstractContextManager[object]] = contextlib.nullcontext,
    ) -> None:
        super().__init__(max_worlds)
        self._compile = functools.partial(compile_world, compiling=compiling)
        self.copy: Callable[[mujoco.MjModel], mujoco.MjModel] = copied_model

    def world(self, key: WorldKey) -> CompiledWorld:
        """The world of `key`, its MjModel a new copy each call (a plant changes its own): from
        what is kept, else compiled (and kept); raises as `compile_world` does."""
        kept = self.kept_or_made(key, self._compile)
        return CompiledWorld(kept.robot, self.copy(kept.mj_model))
