"""Compiled worlds for robot and scene switches: built in a worker process, kept per key.

A switch is built beside the loop (switch.py), on a thread of the sim process that shares the
GIL and the machine's cores with the loop. The robot and MuJoCo's model (lab/world/compiled.py)
are most of that work and are made from a `WorldKey` alone, so one worker process, at lower
priority, builds them and sends them back pickled: pinocchio's URDF parser (which keeps the
GIL: 2-16 ms of CPU per robot) and MuJoCo's compile (which releases it, but processes a robot's
meshes on threads of its own: 0.5-1.4 s the first time in a process, Solo12 at load 25) run
there. Loading a pickled world here costs ~20 ms of CPU for Solo12 (7.4 MB, mostly meshes;
MuJoCo loads its binary model without the GIL, pinocchio its model with it: 1.4-2.5 ms). The
pickles are kept per key (the last MAX_WORLDS), so a switch back to a robot and scene costs
that load alone (docs/reliability.md, "Robot switches").

The worker starts with `start` (a `Switcher(worker=True)`'s, when its thread starts) or the
first world asked for, and again after it died; a build that fails there raises its own error
here. It is opt-in: its first builds stalled the loop on a busy machine (docs/reliability.md).
"""

import multiprocessing
import os
import pickle
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from lab.world.compiled import CompiledWorld, RecentWorlds, WorldKey, compile_world

MAX_WORLDS = 8  # pickled worlds kept (Solo12's 7.5 MB, most of it meshes)
# The worker's niceness: its imports and MuJoCo's compile (threads of its own) share the
# machine's cores with the loop. Started by the first switch at +10: the loop's longest gap
# 51 ms at load 25 (the reply after 20 s); started with the switcher at 0 or +10: 3-5 s at
# load 33-45 (benchmarks/bench_switch.py, docs/reliability.md).
WORKER_NICE = 10


def _lower_priority() -> None:
    """The worker's initializer: run at WORKER_NICE."""
    os.nice(WORKER_NICE)


def _pickled_world(key: WorldKey) -> bytes:
    """In the worker: the world of `key`, pickled."""
    return pickle.dumps(compile_world(key), protocol=pickle.HIGHEST_PROTOCOL)


class WorldCache(RecentWorlds[bytes]):
    """Worlds built in one worker process and kept per key (module docstring); used by one
    thread at a time (the switcher's)."""

    def __init__(self, max_worlds: int = MAX_WORLDS) -> None:
        super().__init__(max_worlds)
        self._pool: ProcessPoolExecutor | None = None

    def world(self, key: WorldKey) -> CompiledWorld:
        """The world of `key`, a new copy each call (a plant changes its MjModel): from the
        cache, else built by the worker (its KeyError or ValueError raised here)."""
        return pickle.loads(self.kept_or_made(key, self._build))

    def _pool_started(self) -> ProcessPoolExecutor:
        if self._pool is None:
            # forkserver: the worker is not a fork of the threaded sim process
            context = multiprocessing.get_context("forkserver")
            self._pool = ProcessPoolExecutor(
                max_workers=1, mp_context=context, initializer=_lower_priority
            )
        return self._pool

    def _build(self, key: WorldKey) -> bytes:
        pool = self._pool_started()
        try:
            return pool.submit(_pickled_world, key).result()
        except BrokenProcessPool:  # the worker died (killed, crashed): the next build starts one
            pool.shutdown(wait=False)
            self._pool = None
            raise

    def start(self) -> None:
        """Start the worker now (its imports take seconds on a busy machine), not with the
        first world asked for."""
        self._pool_started().submit(os.getpid)

    def worker_pid(self) -> int:
        """The worker process's id (it starts if it had not)."""
        return self._pool_started().submit(os.getpid).result()

    def close(self) -> None:
        """Stop the worker, if one started."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
