"""The heap trimmer trims during a flood of command bytes and after it, never when quiet."""

import time

from lab.runtime.heap_trim import HeapTrimmer

INTERVAL_S = 0.05
MIN_BYTES = 1000


def test_heap_is_trimmed_during_a_flood_and_after_it_only() -> None:
    traffic = [0]  # payload bytes read so far
    trims: list[tuple[float, int]] = []  # when, and the traffic then

    def trim() -> bool:
        trims.append((time.monotonic(), traffic[0]))
        return True

    trimmer = HeapTrimmer(lambda: traffic[0], INTERVAL_S, MIN_BYTES, trim)
    try:
        time.sleep(5 * INTERVAL_S)
        assert trims == []  # quiet: never
        deadline = time.monotonic() + 6 * INTERVAL_S
        while time.monotonic() < deadline:  # a flood: 10x the threshold per window
            traffic[0] += MIN_BYTES // 5
            time.sleep(INTERVAL_S / 50)
        during = len(trims)
        time.sleep(12 * INTERVAL_S)  # quiet again
    finally:
        trimmer.close()
    quiet_since = trims[-1][0] if trims else 0.0
    assert during >= 2, trims  # the flood's windows (a loaded machine may stretch one)
    assert trims[-1][1] == traffic[0]  # after the flood's last byte...
    assert trimmer.trims <= during + 2  # ...its last window's and the next one's at most
    assert time.monotonic() - quiet_since > 3 * INTERVAL_S  # ...then none
