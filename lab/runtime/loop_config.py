"""The realtime loop's settings (`lab serve`'s loop flags), each with why it has its default."""

from dataclasses import dataclass

SPIN_CHOICES = ("yield", "busy")


@dataclass(frozen=True)
class LoopConfig:
    rate_hz: float = 1000.0
    fast: bool = False  # no sleeping: run as fast as the CPU allows
    # Scheduling policy of the loop thread: "fifo" asks for SCHED_FIFO (refusal is ignored),
    # "other" keeps SCHED_OTHER, "auto" is "fifo" with AUTO_FIFO_MIN_CPUS CPUs or more, else
    # "other". Fast mode never asks for FIFO: it would starve the machine.
    sched: str = "auto"
    telemetry_hz: float = 100.0
    state_hz: float = 60.0
    max_commands_per_tick: int = 4
    # Sleep until this long before a deadline, then spin. On this project's 2-core VM a sleep
    # woke more than 10 % of a period late on ~1.5 % of ticks (the idle vCPU halts; waking it
    # takes the host 35-50 µs at the median): a short spin keeps the tail in. Spinning the whole
    # period instead gets the loop throttled by the kernel's realtime budget (50 ms stalls at
    # SCHED_FIFO), and at SCHED_OTHER every µs of spin is CPU time EEVDF charges the loop with.
    # 0.05 ms, busy, with the slice below: the best of the settings measured in round 9
    # (docs/performance.md, "Why the loop is built this way").
    spin_s: float = 5e-5
    # Spin for a margin learned instead (lab/runtime/wake_margin.py: a high percentile of how
    # late the loop's own sleeps ended over the last 2 s); spin_s is then unused.
    adaptive_spin: bool = False
    # How to spend the spin: "busy" only reads the clock; "yield" calls sched_yield, which under
    # EEVDF pushes the loop's virtual deadline back a slice, so a runnable neighbour goes first:
    # it doubled the late wake-ups (round 9). The transport's put thread takes the GIL for each
    # put, normally while the loop sleeps; in a spin longer than GIL_HOLD_S the loop drops the
    # GIL until GIL_HOLD_S before the deadline (Zenoh's own threads run no Python; the main
    # thread waits on an Event).
    spin: str = "busy"
    # Let the session warm its next tick before each deadline (`Session.warm`, WARM_LEAD_S
    # earlier: loop.py): the tick starts with MuJoCo's code and model in the caches, for the
    # warm-up's own CPU time (docs/performance.md, "Where the plain tick goes"). Off by default:
    # it saves ~25 µs of the tick for ~50-68 µs of CPU before it, CPU that a local browser on a
    # 2-core machine needs more (`lab serve --warm` turns it on).
    warm: bool = False
    # The EEVDF slice (s) to ask for at SCHED_OTHER (Linux >= 6.12, unprivileged; threads the
    # loop starts keep the default): a waking thread with a shorter slice than the running one
    # preempts it (PREEMPT_SHORT) instead of waiting for that slice to end, which this kernel
    # (HZ=250) notices only at its next 4 ms tick. None keeps the kernel's default (1.4 ms here).
    slice_s: float | None = 1e-4
    # The nice value to ask for at SCHED_OTHER (a negative one needs CAP_SYS_NICE or a raised
    # RLIMIT_NICE; refusal is expected and ignored). EEVDF weighs a thread ~1.25x per step: at
    # -10 the loop weighs 9.3 default threads, so the CPU time it spends does not push its
    # virtual deadline behind its neighbours' and its wake-ups still preempt them. Unlike
    # SCHED_FIFO it cannot starve them: they keep their fair share. None leaves it as it is.
    nice: int | None = -10
    # The interpreter's switch interval (sys.setswitchinterval) while the loop runs in real
    # time: how long the loop, woken for a tick, waits at most for the GIL when another thread
    # of the process (the command intake under a flood, a switch being built) holds it. Python's
    # default, 5 ms, is five periods (issue 25, docs/reliability.md). None leaves it.
    switch_interval_s: float | None = 2e-4
    # Measure the machine's floor first, for this long (s): the loop with nothing to do between
    # deadlines (lab/runtime/floor.py; the `floor` command measures it again). 0: not at
    # start. Fast mode never measures it.
    floor_s: float = 0.0
