"""Memory the C heap keeps after it is freed, given back to the system.

A robot switch frees a whole session (MuJoCo model and data, pinocchio models, the native
kernel) and builds another; glibc's malloc keeps much of what was freed in its arenas (its
mmap threshold grows with the largest block freed, so later blocks of that size come from the
heap, where fragmentation holds them). Measured (issue 25, headless, 100 ANYmal/Solo12 switches):
the resident memory grew 13 MB without trimming; with `malloc_trim` every ten switches it stayed
at 194.9-195.1 MB for 90 of them (a 7 MB step at the 100th). The memory was free, only not
returned (docs/reliability.md).
"""

import ctypes
import ctypes.util
import functools


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
