"""Memory the C heap keeps after it is freed, given back to the system, and what it holds.

A robot switch frees a whole session (MuJoCo model and data, pinocchio models, the native
kernel) and builds another. glibc's malloc gives each block of its mmap threshold or more a
mapping of its own, returned to the system when freed, but by default it raises the threshold
to the size of each such block freed (up to 32 MiB): after the first switch a MuJoCo model's
buffer (Solo12: 7.4 MB, one block) came from the heap, where free blocks stayed resident
between the live ones. The resident memory's floor over 200 Solo12 switches then stepped by one
or two models (-2 to +6 %, either copy of the model) and the arenas kept 300-700 MB free
(`heap_usage`). `map_large_blocks`, which the sim process calls as it starts (lab serve), fixes
the threshold at LARGE_BLOCK_BYTES: the floor moved by +0.7 to +1.2 % (+2.5 % over 600
switches) and the arenas kept 40-60 MB free (benchmarks/bench_switch_memory.py,
docs/reliability.md). The smaller blocks a switch frees are still kept in the
arenas until `release_free_memory` trims them. A flood of commands leaves free memory the same
way through Zenoh's threads (lab/runtime/heap_trim.py); `heap_usage` tells the two apart (in
use, or free and kept).
"""

import contextlib
import ctypes
import ctypes.util
import functools
import gc
from collections.abc import Iterator

# glibc's mmap threshold as the sim process fixes it (`map_large_blocks`): below the MuJoCo
# models of more than a few kB (Go2's 1.8 MB, Solo12's 7.4), far above what the loop allocates
# again and again, so that no tick maps and unmaps memory (`lab serve --robot g1` ticking with
# its UI connected, mmap calls traced for 10-15 s: at a 4 KiB threshold ~120 a second, 8-12 KiB
# each; at 32 KiB none).
LARGE_BLOCK_BYTES = 1 << 20
M_MMAP_THRESHOLD = -3  # mallopt's parameter (malloc.h)


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


def map_large_blocks(threshold: int = LARGE_BLOCK_BYTES) -> bool:
    """From now on every block of the C heap of `threshold` bytes or more is a mapping of its
    own, returned to the system when freed (glibc's `mallopt(M_MMAP_THRESHOLD)`, which also
    stops glibc raising the threshold to the largest block freed: the module). False where
    there is no such call (another C library) or glibc refuses the value (over 32 MiB)."""
    libc = _libc()
    mallopt = getattr(libc, "mallopt", None) if libc is not None else None
    return mallopt is not None and mallopt(M_MMAP_THRESHOLD, threshold) == 1


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
