"""Linux scheduling for the realtime loop's thread: the policy (SCHED_FIFO or SCHED_OTHER), its
EEVDF slice and nice value (sched_setattr(2), which Python's os module lacks: ctypes), the
timer slack, and how many CPUs the process may use. Every request changes the calling thread
only, is refused quietly when not allowed, and is not passed on to threads it starts later."""

import contextlib
import ctypes
import os
import platform
import threading

FIFO_PRIORITY = 50
SCHED_CHOICES = ("auto", "fifo", "other")
# `auto` takes SCHED_FIFO only with this many CPUs to run on. On a 2-core machine a 1 kHz FIFO
# loop left the UI process and a local browser so little that a click took up to 4 s to reach
# the sim (issue 16); with 4 or more, one core for the loop leaves enough for the rest. Round 8
# measured FIFO on 2 cores again (docs/performance.md, "Why the loop is built this way"): far more
# ticks on time than SCHED_OTHER under load and no 4 s clicks, but short of 99.9 %: kept for now.
# Round 9 ("The 1 kHz loop on EEVDF"): with jobs split over ticks, FIFO 96.6-98.9 % against
# SCHED_OTHER's 95-97 % at low load; its starvation not measured again: still kept.
AUTO_FIFO_MIN_CPUS = 4
_PR_SET_TIMERSLACK = 29
_PR_SET_NAME = 15
# sched_setattr(2) / sched_getattr(2): not in Python's os module.
_SYS_SCHED_SETATTR = {"x86_64": 314, "aarch64": 274}
_SYS_SCHED_GETATTR = {"x86_64": 315, "aarch64": 275}
_SCHED_OTHER = 0
_SCHED_FLAG_RESET_ON_FORK = 1
# The custom slices the kernel accepts (it clamps to these; kernel/sched/syscalls.c).
SLICE_MIN_S, SLICE_MAX_S = 1e-4, 0.1


def lower_timer_slack() -> None:
    """Ask for 1 ns timer slack for the calling thread (default 50 µs); ignore refusal."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_TIMERSLACK, ctypes.c_ulong(1), 0, 0, 0)


def name_os_thread() -> None:
    """Give the calling thread's Python name (its first 15 bytes) to the OS thread, for
    /proc/<pid>/task/*/comm, top -H and benchmarks/bench_load.py's CPU time by thread (Python
    3.11 leaves every thread named after the process); ignore refusal."""
    name = threading.current_thread().name.encode()[:15]
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_NAME, ctypes.c_char_p(name), 0, 0, 0)


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def resolve_sched(requested: str, cpus: int) -> str:
    """The policy to ask for, "fifo" or "other", for LoopConfig.sched `requested`."""
    if requested not in SCHED_CHOICES:
        raise ValueError(f"unknown scheduling {requested!r} (choices: {', '.join(SCHED_CHOICES)})")
    if requested == "auto":
        return "fifo" if cpus >= AUTO_FIFO_MIN_CPUS else "other"
    return requested


def request_fifo() -> bool:
    """Ask for SCHED_FIFO for the calling thread; True if granted. Refusal (no privileges) is
    expected and ignored. Threads it starts later (Zenoh spawns some lazily) do not inherit the
    realtime priority (SCHED_RESET_ON_FORK): only the loop itself may starve the machine."""
    policy = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
    try:
        os.sched_setscheduler(0, policy, os.sched_param(FIFO_PRIORITY))
    except (OSError, AttributeError):
        return False
    return True


class _SchedAttr(ctypes.Structure):
    """struct sched_attr, its first version (SCHED_ATTR_SIZE_VER0: 48 bytes)."""

    _fields_ = [
        ("size", ctypes.c_uint32),
        ("sched_policy", ctypes.c_uint32),
        ("sched_flags", ctypes.c_uint64),
        ("sched_nice", ctypes.c_int32),
        ("sched_priority", ctypes.c_uint32),
        ("sched_runtime", ctypes.c_uint64),
        ("sched_deadline", ctypes.c_uint64),
        ("sched_period", ctypes.c_uint64),
    ]


def _sched_attr_call(table: dict[str, int], attr: _SchedAttr, *extra: int, tid: int = 0) -> bool:
    """sched_getattr/sched_setattr on thread `tid` (0: the calling one), made with the GIL
    released (a ctypes call); False when refused or unavailable."""
    number = table.get(platform.machine())
    if number is None:
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.syscall(number, tid, ctypes.byref(attr), *extra, 0) == 0
    except (OSError, AttributeError):
        return False


def _fair_attr() -> _SchedAttr | None:
    """The calling thread's sched_getattr, or None when unavailable or it is not SCHED_OTHER."""
    attr = _SchedAttr(size=ctypes.sizeof(_SchedAttr))
    if not _sched_attr_call(_SYS_SCHED_GETATTR, attr, ctypes.sizeof(_SchedAttr)):
        return None
    return attr if attr.sched_policy == _SCHED_OTHER else None


def _change_fair_attr(runtime_ns: int, nice: int | None) -> bool:
    """sched_setattr on the calling SCHED_OTHER thread: `runtime_ns` (its EEVDF slice; 0 is the
    kernel's default) and, unless None, `nice` (else the one it has), with
    SCHED_FLAG_RESET_ON_FORK, so that threads it starts later get neither. False when refused,
    unavailable, or the thread is not SCHED_OTHER; the thread is then left as it was."""
    attr = _fair_attr()
    if attr is None:
        return False
    attr.size = ctypes.sizeof(_SchedAttr)
    attr.sched_flags |= _SCHED_FLAG_RESET_ON_FORK
    attr.sched_runtime = runtime_ns
    if nice is not None:
        attr.sched_nice = nice
    return _sched_attr_call(_SYS_SCHED_SETATTR, attr)


def request_slice(seconds: float) -> float | None:
    """Ask for an EEVDF slice of `seconds` for the calling SCHED_OTHER thread (sched_setattr's
    sched_runtime; Linux >= 6.12, no privileges needed, clamped to SLICE_MIN_S..SLICE_MAX_S).
    A waking thread whose slice is shorter than the running thread's preempts it at once
    instead of waiting for that slice to end. Returns the slice in effect (s) as the kernel
    reads it back, or None when refused, unsupported (an older kernel ignores the field and
    reads back 0) or the thread is not SCHED_OTHER; the thread is then left as it was. Threads
    it starts later get the default slice (SCHED_FLAG_RESET_ON_FORK)."""
    if not _change_fair_attr(max(1, round(seconds * 1e9)), nice=None):
        return None
    return thread_slice()


def request_nice(nice: int) -> int | None:
    """Ask for nice value `nice` for the calling SCHED_OTHER thread (sched_setattr's sched_nice;
    it also resets the thread's EEVDF slice to the kernel's default: ask for a slice after it,
    `request_slice` keeps the nice). Raising the priority (a negative nice) needs CAP_SYS_NICE or
    a raised RLIMIT_NICE: refusal is expected, and leaves the thread as it was. Threads it starts
    later get nice 0 (SCHED_FLAG_RESET_ON_FORK). Returns the nice in effect, or None when
    refused, unavailable, or the thread is not SCHED_OTHER."""
    if not _change_fair_attr(0, nice):
        return None
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def thread_slice() -> float | None:
    """The calling SCHED_OTHER thread's EEVDF slice (s): its custom one, else the kernel's
    default; None for other policies, and on kernels without custom slices (they read back 0)."""
    attr = _fair_attr()
    if attr is None or attr.sched_runtime == 0:
        return None
    return attr.sched_runtime * 1e-9


class ThreadPolicy:
    """One thread's scheduling attributes as read now (sched_getattr: policy, priority, nice,
    EEVDF slice), to give it SCHED_FIFO for a while and then these back: what a robot switch
    does to the loop's thread and its own (lab/runtime/switch.py). Both calls are made with the
    GIL released, so that a thread lowering its own priority is not preempted holding it."""

    def __init__(self, tid: int, attr: _SchedAttr) -> None:
        self.tid = tid  # the thread's native id (threading.get_native_id)
        self._attr = attr

    @classmethod
    def of(cls, tid: int) -> "ThreadPolicy | None":
        """Thread `tid`'s attributes now; None when unavailable (not Linux, no such thread)."""
        attr = _SchedAttr(size=ctypes.sizeof(_SchedAttr))
        if not _sched_attr_call(_SYS_SCHED_GETATTR, attr, ctypes.sizeof(_SchedAttr), tid=tid):
            return None
        return cls(tid, attr)

    @property
    def fifo_priority(self) -> int:
        """The thread's SCHED_FIFO priority as read (0 when it was not SCHED_FIFO)."""
        return int(self._attr.sched_priority) if self._attr.sched_policy == os.SCHED_FIFO else 0

    def fifo(self, priority: int) -> bool:
        """Put the thread at SCHED_FIFO `priority` (threads it starts later do not inherit it:
        SCHED_FLAG_RESET_ON_FORK); False when refused (no CAP_SYS_NICE) or unavailable."""
        attr = _SchedAttr(size=ctypes.sizeof(_SchedAttr), sched_policy=os.SCHED_FIFO)
        attr.sched_flags = _SCHED_FLAG_RESET_ON_FORK
        attr.sched_priority = priority
        return _sched_attr_call(_SYS_SCHED_SETATTR, attr, tid=self.tid)

    def restore(self) -> bool:
        """Give the thread the attributes it had when read; False when refused or gone."""
        self._attr.size = ctypes.sizeof(_SchedAttr)
        return _sched_attr_call(_SYS_SCHED_SETATTR, self._attr, tid=self.tid)
