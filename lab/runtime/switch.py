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
thread. So the thread asks for the loop's nice (`LoopConfig.nice`) when it starts; and while a
switch is under way (its build, the swap, the old parts freed) the thread runs at SCHED_FIFO and
the loop's thread (the one that called `start`) at SCHED_FIFO one above it (`Realtime`), then
both get their own scheduling back. Nothing the machine runs at SCHED_OTHER then preempts the
thread holding the GIL, and the loop preempts the thread whenever it wakes. MuJoCo's compile
(which releases the GIL and runs threads of its own, up to seconds on a robot's first build)
runs at the thread's own scheduling. At nice -10 alone, a switch's longest loop gap was 2-3
times the machine's own (docs/reliability.md, "Robot switches"). A build's allocations can start
Python's full garbage collection, which holds the GIL for as long as it scans: the realtime loop
freezes what exists when it starts (loop.py), so that it scans little.
"""

import contextlib
import functools
import queue
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from lab.runtime.intake import Request
from lab.runtime.loop_config import LoopConfig
from lab.runtime.scheduling import ThreadPolicy, request_nice
from lab.runtime.world_cache import WorldCache
from lab.world.compiled import CompiledWorld, KeptWorlds, WorldKey, world_key
from lab.world.memory import release_free_memory
from lab.world.session_parts import SessionConfig, SessionParts, build_parts

SWITCH_FIFO_PRIORITY = 1  # the switch's thread during a switch: above every SCHED_OTHER thread
# How long the thread waits, raised, for the loop to swap a built switch in and hand back the
# old parts before it lowers itself and the loop anyway (the loop swaps within a tick or two).
SWAP_WAIT_S = 1.0


class Realtime:
    """The switch's thread at SCHED_FIFO `SWITCH_FIFO_PRIORITY`, and the loop's thread at
    SCHED_FIFO one above it (or at its own FIFO priority if higher), while a switch is under
    way; each thread's own scheduling back after (see the module). Both or neither: refused (no
    CAP_SYS_NICE), both stay as they are. The loop raises both as it starts a switch (so the
    switch's thread wakes at once), the switch's thread releases them once per switch; a
    switch started before the last one was released (its old parts still being freed) keeps
    them raised."""

    def __init__(self, enabled: bool = True) -> None:
        """`enabled` False: never raise (both threads stay at their own scheduling)."""
        self.enabled = enabled
        self.rises = 0  # switches started raised
        self._lock = threading.Lock()
        self._switches = 0  # switches raised and not released yet
        self._held: list[ThreadPolicy] = []  # the threads raised, as they were: the loop's first

    @property
    def raised(self) -> bool:
        """Whether the two threads are at SCHED_FIFO for a switch now."""
        return bool(self._held)

    def rise(self, loop_tid: int, switch_tid: int) -> None:
        """For one more switch: raise the loop's thread and the switch's, if not yet."""
        with self._lock:
            if not self.enabled:
                return
            self._switches += 1
            if not self._held:
                self._held = _raised(loop_tid, switch_tid)
            self.rises += bool(self._held)

    def release(self) -> None:
        """One switch is over: the threads their own scheduling back when it was the last (the
        loop's first: the switch's thread stays above the machine while it holds the GIL)."""
        with self._lock:
            self._switches = max(0, self._switches - 1)
            if self._switches == 0:
                held, self._held = self._held, []
                for policy in held:
                    policy.restore()  # a loop thread that has ended is gone: nothing to restore

    @contextlib.contextmanager
    def lowered(self) -> Iterator[None]:
        """The switch's thread (the caller) at its own scheduling for the block, raised again
        after it: MuJoCo's compile, which runs without the GIL for up to seconds (the loop
        stays raised, so no thread at SCHED_OTHER holds it back meanwhile)."""
        with self._lock:
            own = self._held[1] if self._held else None
            if own is not None:
                own.restore()
        try:
            yield
        finally:
            with self._lock:
                if own is not None and self._held:
                    own.fifo(SWITCH_FIFO_PRIORITY)


def _raised(loop_tid: int, switch_tid: int) -> list[ThreadPolicy]:
    """Both threads at SCHED_FIFO, returned as they were (the loop's first); neither if either
    is refused."""
    loop, own = ThreadPolicy.of(loop_tid), ThreadPolicy.of(switch_tid)
    if loop is None or own is None or not own.fifo(SWITCH_FIFO_PRIORITY):
        return []
    if not loop.fifo(max(loop.fifo_priority, SWITCH_FIFO_PRIORITY + 1)):
        own.restore()
        return []
    return [loop, own]


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
        realtime: bool = True,
    ) -> None:
        """`build` makes a switch's parts; by default `build_parts` with its robot and MuJoCo
        model kept per robot and scene in this process (`kept`), or with `worker` from the
        worker process and its cache (`worlds`, see the module). `nice`: the thread's (None: as
        it starts; a refusal leaves it so). `realtime`: whether a switch raises the thread and
        the loop's to SCHED_FIFO while it is under way (`Realtime`)."""
        self._nice = nice
        self.realtime = Realtime(realtime)
        self.worlds = WorldCache()
        self.kept = KeptWorlds(compiling=self.realtime.lowered)
        self._start_worker = worker  # the first switch need not wait for its start
        self._world = self._from_worker if worker else self.kept.world
        if build is None:
            build = functools.partial(build_parts, world=self._world)
        self._build = build
        self._jobs: queue.SimpleQueue[
            tuple[Request, SessionConfig] | SessionParts | WorldKey | None
        ] = queue.SimpleQueue()
        self._swap_due = False  # a switch is built and raised: its old parts are to come back
        self._done: queue.SimpleQueue[Built] = queue.SimpleQueue()
        self.pending: Request | None = None  # the switch under way
        self._thread = threading.Thread(target=self._run, name="session-switch", daemon=True)
        self._thread.start()

    def start(self, request: Request, config: SessionConfig) -> None:
        """Build the parts of `config` for `request` (only when no switch is `pending`); called
        on the loop's thread, which runs at SCHED_FIFO until the switch is over (`Realtime`)."""
        self.pending = request
        if (switch_tid := self._thread.native_id) is not None:
            self.realtime.rise(threading.get_native_id(), switch_tid)
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

    def _from_worker(self, key: WorldKey) -> CompiledWorld:
        """The world of `key` from the worker process (its build takes seconds: the threads at
        their own scheduling meanwhile)."""
        with self.realtime.lowered():
            return self.worlds.world(key)

    def _next_job(self) -> tuple[Request, SessionConfig] | SessionParts | WorldKey | None:
        """The next job; after a switch built, the switch is released if its old parts do not
        come back within SWAP_WAIT_S (the loop did not swap it in)."""
        if self._swap_due:
            try:
                return self._jobs.get(timeout=SWAP_WAIT_S)
            except queue.Empty:
                self._swapped()
        return self._jobs.get()

    def _swapped(self) -> None:
        """The switch built last is over (its old parts freed, or not swapped in)."""
        if self._swap_due:
            self._swap_due = False
            self.realtime.release()

    def _run(self) -> None:
        if self._nice is not None:
            request_nice(self._nice)
        if self._start_worker:
            self.worlds.start()
        try:
            self._serve()
        finally:
            self._swapped()

    def _serve(self) -> None:
        while (job := self._next_job()) is not None:
            if isinstance(job, WorldKey):
                with contextlib.suppress(KeyError, ValueError):  # a switch to it will say why
                    self._world(job)
                continue
            if isinstance(job, SessionParts):
                del job  # the last reference: the old session's parts are freed here
                release_free_memory()
                self._swapped()
                continue
            self._swapped()  # a switch started with no swap of the last one: it is over
            request, config = job
            built = self._built(request, config)
            if built.parts is None:
                self.realtime.release()  # refused: no swap and nothing to free
            else:
                self._swap_due = True
            self._done.put(built)

    def _built(self, request: Request, config: SessionConfig) -> Built:
        """The parts of `config`, or why there are none."""
        try:
            return Built(request, self._build(config), None)
        except (KeyError, ValueError) as error:  # an unknown robot or scene, or a scene made
            # for another robot: the message names what there is
            message = error.args[0] if isinstance(error, KeyError) else str(error)
            return Built(request, None, f"{request.verb}: {message}")
        except Exception as error:  # a fault building it is a refused switch, never a stop
            message = f"{request.verb}: could not build {config.robot} in {config.scene}"
            return Built(request, None, f"{message}: {type(error).__name__}: {error}")
