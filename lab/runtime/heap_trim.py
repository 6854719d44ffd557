"""The C heap a flood of commands used, given back to the system while and after it happens.

Under a flood of 64 KB commands the sim process's resident memory grew ~29 MB in two minutes and
kept it after the flood (issue 25). Measured with glibc's statistics (benchmarks/
zenoh_flood_memory.py, `malloc` columns): almost all of it is memory Zenoh's threads allocated
for the queries and freed again, which glibc keeps in its arenas; what is still in use after the
flood is 0.4 MB, as much as a bare Zenoh queryable keeps. So a thread (`HeapTrimmer`) looks
every TRIM_INTERVAL_S at how many payload bytes the command intake read (`traffic`), and after
a window with at least TRIM_MIN_BYTES of them (a flood, or its end: the window after one) calls
glibc's `malloc_trim` (lab/world/memory.py, without the GIL). Quiet labs never trim.
"""

import threading
from collections.abc import Callable

from lab.runtime.scheduling import name_os_thread
from lab.world.memory import release_free_memory

TRIM_INTERVAL_S = 2.0  # how often the traffic is looked at (a trim then costs 0.05-5 ms)
# payload bytes read in one window that make it worth a trim (a normal load: 3 clients at 50 Hz
# sending ~100-byte commands, 15 KB/s, never reaches it)
TRIM_MIN_BYTES = 4 * 1024 * 1024


class HeapTrimmer:
    """Trims the C heap after each window of heavy command traffic (module docstring)."""

    def __init__(
        self,
        traffic: Callable[[], int],
        interval_s: float = TRIM_INTERVAL_S,
        min_bytes: int = TRIM_MIN_BYTES,
        trim: Callable[[], bool] = release_free_memory,
    ) -> None:
        """`traffic()`: the payload bytes read so far (a counter that only grows)."""
        self._traffic, self._interval, self._min_bytes = traffic, interval_s, min_bytes
        self._trim = trim
        self.trims = 0  # trims done
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="heap-trim", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        name_os_thread()
        seen, busy_before = self._traffic(), False
        while not self._stop.wait(self._interval):
            now = self._traffic()
            busy = now - seen >= self._min_bytes
            seen = now
            if busy or busy_before:  # during a flood, and once in the window after it
                self._trim()
                self.trims += 1
            busy_before = busy

    def close(self) -> None:
        """Stop the thread."""
        self._stop.set()
        self._thread.join()
