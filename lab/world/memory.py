"""Memory the C heap keeps after it is freed, given back to the system, and what it holds.

A robot switch frees a whole session (MuJoCo model and data, pinocchio models, the native
kernel) and builds another; glibc's malloc keeps much of what was freed in its arenas (its
mmap threshold grows with the largest block freed, so later blocks of that size come from the
heap, where fragmentation holds them). Measured (issue 25, headless, 100 ANYmal/Solo12 switches):
the resident memory grew 13 MB without trimming; with `malloc_trim` every ten switches it stayed
at 194.9-195.1 MB for 90 of them (a 7 MB step at the 100th). The memory was free, only not
returned (docs/reliability.md). A flood of commands does the same through Zenoh's threads
(lab/runtime/heap_trim.py); `heap_usage` tells the two apart (in use, or free and kept).
"""

import contextlib
import ctypes
import ctypes.util
import functools
import gc
from collections.abc import Iterator


class _MallInfo2(ctypes.Structure):
    """glibc's `struct mallinfo2` (malloc.h, glibc >= 2.33), every field a size_t."""

    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena",  # bytes of the arenas' heaps (sbrk and mmap'ed heaps)
            "ordblks",
            "smblks",
            "hblks",
            "hblkhd",  # bytes in blocks mmap'ed one each (large ones)
            "usmblks",
            "fsmblks",
            "uordblks",  # bytes in use in the heaps
            "fordblks",  # bytes free in the heaps: kept by malloc, not returned
            "keepcost",
        )
    ]


@functools.cache
def _libc() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name) if name else None
    except OSError:
        return None


def release_free_memory() -> bool:
    """Return the C heap's free memory to the system (glibc's `malloc_trim(0)`; ctypes drops
    the GIL for the call). False where there is no such call (another C library)."""
    libc = _libc()
    trim = getattr(libc, "malloc_trim", None) if libc is not None else None
    if trim is None:
        return False
    trim(0)
    return True


def heap_usage() -> dict[str, float] | None:
    """The C heap over all of glibc's arenas (MB): `in_use` by live allocations (malloc'ed
    blocks, the large mmap'ed ones included) and `free_kept` (freed, kept in the arenas, part of
    the resident memory until trimmed); None without glibc's `mallinfo2`."""
    libc = _libc()
    mallinfo2 = getattr(libc, "mallinfo2", None) if libc is not None else None
    if mallinfo2 is None:
        return None
    mallinfo2.restype = _MallInfo2
    info = mallinfo2()
    mb = 1.0 / (1 << 20)
    return {
        "in_use": round((info.uordblks + info.hblkhd) * mb, 1),
        "free_kept": round(info.fordblks * mb, 1),
    }


@contextlib.contextmanager
def long_lived_objects_frozen() -> Iterator[None]:
    """Within: what exists now is in the garbage collector's permanent generation, so the
    collections that ticking triggers scan only what came after (a full collection of the
    imports' objects takes tens of ms; the realtime loop does the same, runtime/loop.py).
    Unfrozen after, so that the last collection at exit still frees them."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
