"""Robot and scene switches built beside the loop, so that a switch does not stall it.

A `robot` or `scene` command rebuilds the session: URDF, pinocchio model, MuJoCo compile,
the native kernel: 0.5-1 s here. `Switcher` builds the new parts (`build_parts`) on a thread
of its own while the loop keeps ticking the old robot; the loop swaps them in between two ticks
(`Session.install`) and answers the command then. The old parts are handed back to the thread,
freed there, and the C heap's free memory is returned to the system (lab/world/memory.py).
One switch at a time: another one while a switch is under way is refused, naming it.

While it builds, the thread shares the GIL with the loop: the loop's `switch_interval_s`
(LoopConfig) bounds how long the loop waits for it while the thread runs Python, but a C call
keeps the GIL to its end unless it releases it. MuJoCo's compile releases it; pinocchio's URDF
parser and model serialization keep it for milliseconds; the native kernel's set-up no longer
keeps it. So the robot and MuJoCo's model are kept per robot and scene (`kept`,
lab/world/compiled.py `KeptWorlds`; `keep` builds the running robot's as `lab serve` starts):
a switch back shares the robot and copies the model, without the URDF parse and the compile.
With `worker=True` the robot and MuJoCo's model are built in a worker process and kept
per robot and scene (world_cache.py): a switch back costs a load, but a robot's first build
there left the 1 kHz loop gaps of seconds on a machine at load 33-45, for reasons not found, so
it is off by default (docs/reliability.md, "Robot switches").
A GIL held by a thread the host preempts stays held until the thread runs again: on a busy
machine a millisecond's hold became tens of them, the loop (at nice -10) waiting behind a nice-0
thread. So the thread asks for the loop's nice (`LoopConfig.nice`) when it starts. A build's
allocations can start Python's full garbage collection, which holds the GIL for as long as it
scans: the realtime loop freezes what exists when it starts (loop.py), so that it scans little.
"""

import contextlib
import functools
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass

from lab.runtime.intake import Request
from lab.runtime.loop_config import LoopConfig
from lab.runtime.scheduling import request_nice
from lab.runtime.world_cache import WorldCache
from lab.world.compiled import KeptWorlds, WorldKey, world_key
from lab.world.memory import release_free_memory
from lab.world.session_parts import SessionConfig, SessionParts, build_parts


@dataclass(frozen=True)
class Built:
    """A finished switch: the command's request, and the new parts or why there are none."""

    request: Request
    parts: SessionParts | None
    error: str | None


class Switcher:
    """Builds session parts for one switch at a time on its own thread (see the module)."""

    def __init__(
        self,
        build: Callable[[SessionConfig], SessionParts] | None = None,
        nice: int | None = LoopConfig.nice,
        worker: bool = False,
    ) -> None:
        """`build` makes a switch's parts; by default `build_parts` with its robot and MuJoCo
        model kept per robot and scene in this process (`kept`), or with `worker` from the
        worker process and its cache (`worlds`, see the module). `nice`: the thread's (None: as
        it starts; a refusal leaves it so)."""
        self._nice = nice
        self.worlds = WorldCache()
        self.kept = KeptWorlds()
        self._start_worker = worker  # the first switch need not wait for its start
        self._world = self.worlds.world if worker else self.kept.world
        if build is None:
            build = functools.partial(build_parts, world=self._world)
        self._build = build
        self._jobs: queue.SimpleQueue[
            tuple[Request, SessionConfig] | SessionParts | WorldKey | None
        ] = queue.SimpleQueue()
        self._done: queue.SimpleQueue[Built] = queue.SimpleQueue()
        self.pending: Request | None = None  # the switch under way
        self._thread = threading.Thread(target=self._run, name="session-switch", daemon=True)
        self._thread.start()

    def start(self, request: Request, config: SessionConfig) -> None:
        """Build the parts of `config` for `request` (only when no switch is `pending`)."""
        self.pending = request
        self._jobs.put((request, config))

    def keep(self, config: SessionConfig) -> None:
        """Compile the world of `config` (robot, scene) on the thread and keep it (`kept`), so
        that a later switch to it loads rather than parses and compiles (with `worker`, the
        worker builds it): the running session's, as `lab serve` starts, so that a switch back
        to it is no first build."""
        self._jobs.put(world_key(config.robot, config.scene, config.timestep, config.terrain_seed))

    def finished(self) -> Built | None:
        """The switch built since the last call, if any (then nothing is pending)."""
        try:
            built = self._done.get_nowait()
        except queue.Empty:
            return None
        self.pending = None
        return built

    def discard(self, old: SessionParts) -> None:
        """Free `old` (a session's replaced parts) on the thread, then trim the C heap."""
        self._jobs.put(old)

    def close(self) -> None:
        """Finish what is queued, then stop the thread."""
        self._jobs.put(None)
        self._thread.join()
        self.worlds.close()

    def _run(self) -> None:
        if self._nice is not None:
            request_nice(self._nice)
        if self._start_worker:
            self.worlds.start()
        while (job := self._jobs.get()) is not None:
            if isinstance(job, WorldKey):
                with contextlib.suppress(KeyError, ValueError):  # a switch to it will say why
                    self._world(job)
                continue
            if isinstance(job, SessionParts):
                del job  # the last reference: the old session's parts are freed here
                release_free_memory()
                continue
            request, config = job
            try:
                self._done.put(Built(request, self._build(config), None))
            except (KeyError, ValueError) as error:  # an unknown robot or scene, or a scene
                # made for another robot: the message names what there is
                message = error.args[0] if isinstance(error, KeyError) else str(error)
                self._done.put(Built(request, None, f"{request.verb}: {message}"))
            except Exception as error:  # a fault building it is a refused switch, never a stop
                message = f"{request.verb}: could not build {config.robot} in {config.scene}"
                self._done.put(Built(request, None, f"{message}: {type(error).__name__}: {error}"))
