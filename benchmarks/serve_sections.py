"""`lab serve` with a section timer on the loop's ticks (a benchmark tool, not a test; issue 31):
where a tick's time goes between the loop waking and the next sleep.

    .venv/bin/python benchmarks/serve_sections.py OUT.json [lab serve's arguments]

`bench_server.py --sections` starts the server through this. Each tick's `SimLoop._iterate` is
split, with `time.perf_counter`, into the command intake (`_apply_commands`), the session's tick
(`Session.tick`; of it the native crossing, `NativeTick.call_us`, measured inside C++), the work
beside the tick (`_after_tick`: telemetry, drawing state, publishing, statistics) and the rest
(the switch check, the deadman); and apart, before the iteration, the session's warm-up in the
spin before the deadline (`Session.warm`, 0 when the loop did not warm that tick). At exit
OUT.json gets the median µs of each by the tick's kind (TICK_KINDS), over the ticks after the
first quarter (start-up). The timer's own wrappers add a few µs a tick (most of `rest`: 4 µs at
load 40); compare runs that both have it.
"""

import atexit
import json
import sys
import time
from collections.abc import Callable

import numpy as np

from lab.runtime import loop
from lab.runtime.deadline_stats import TICK_KINDS
from lab.runtime.serve import serve_main
from lab.world.session import Session

SECTIONS = ("commands", "session_tick", "native_crossing", "beside", "rest", "iterate", "warm")
MAX_TICKS = 600_000  # 10 min at 1 kHz


class SectionTimer:
    """Per tick, the seconds of each of SECTIONS and the tick's kind."""

    def __init__(self) -> None:
        self.rows = np.zeros((MAX_TICKS, len(SECTIONS)))
        self.kinds: list[str] = []
        self._current = dict.fromkeys(SECTIONS, 0.0)

    def timed(self, section: str, method: Callable) -> Callable:
        """`method` (of a class), its time added to `section` of the current tick."""
        clock, current = time.perf_counter, self._current

        def wrapper(*args: object) -> object:
            start = clock()
            try:
                return method(*args)
            finally:
                current[section] += clock() - start

        return wrapper

    def install(self) -> None:
        """Wrap the loop's and the session's methods (before the server builds them)."""
        loop.SimLoop._apply_commands = self.timed("commands", loop.SimLoop._apply_commands)
        loop.SimLoop._after_tick = self.timed("beside", loop.SimLoop._after_tick)
        tick = self.timed("session_tick", Session.tick)

        def session_tick(session: Session) -> None:
            tick(session)
            native = session.native_tick
            if native._tick is not None and not session.tick_note:
                self._current["native_crossing"] += native.call_us * 1e-6

        Session.tick = session_tick
        Session.warm = self.timed("warm", Session.warm)
        iterate = loop.SimLoop._iterate
        clock, current = time.perf_counter, self._current

        def timed_iterate(simloop: loop.SimLoop, now: float) -> str:
            for key in current:
                if key != "warm":  # the warm-up ran before the iteration, in the spin
                    current[key] = 0.0
            start = clock()
            kind = iterate(simloop, now)
            current["iterate"] = clock() - start
            if len(self.kinds) < MAX_TICKS:
                inside = current["commands"] + current["session_tick"] + current["beside"]
                current["rest"] = current["iterate"] - inside
                self.rows[len(self.kinds)] = [current[s] for s in SECTIONS]
                self.kinds.append(kind)
            current["warm"] = 0.0
            return kind

        loop.SimLoop._iterate = timed_iterate

    def medians(self) -> dict[str, dict[str, float]]:
        """Median µs of each section by tick kind (and over all ticks), after start-up."""
        n = len(self.kinds)
        rows, kinds = self.rows[n // 4 : n], np.array(self.kinds[n // 4 : n])
        out = {}
        for kind in (*TICK_KINDS, "all"):
            chosen = rows if kind == "all" else rows[kinds == kind]
            if len(chosen):
                medians = np.median(chosen, axis=0) * 1e6
                out[kind] = {"ticks": len(chosen)} | {
                    s: round(float(m), 2) for s, m in zip(SECTIONS, medians, strict=True)
                }
        return out


def main() -> int:
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    out, args = sys.argv[1], sys.argv[2:]
    timer = SectionTimer()
    timer.install()

    def dump() -> None:
        with open(out, "w") as f:
            json.dump(timer.medians(), f, indent=1)

    atexit.register(dump)
    return serve_main(args)


if __name__ == "__main__":
    sys.exit(main())
