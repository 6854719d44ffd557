"""The loop's own events (docs/protocol.md, `lab/event`): `overrun`, `stall` and
`rejected_command` (the session's refusals and the intake's), each kind folded to at most one
message per EVENT_INTERVAL_S however many there were."""

import math

EVENT_INTERVAL_S = 1.0  # overrun / rejected_command / stall events: at most one per second each
# Woken this late, the loop stood still (the process stopped by SIGSTOP or a debugger, the
# machine starved): a `stall` event says for how long. Shorter lateness is an overrun's.
STALL_S = 0.2


class EventThrottle:
    """Folds bursts of one kind of event into at most one message per `EVENT_INTERVAL_S`."""

    def __init__(self) -> None:
        self.pending = 0
        self._last = -math.inf

    def hit(self) -> None:
        self.pending += 1

    def take(self, now: float) -> int:
        """How many hits to report now (0 when nothing is due)."""
        if self.pending == 0 or now - self._last < EVENT_INTERVAL_S:
            return 0
        count, self.pending, self._last = self.pending, 0, now
        return count


class LoopEvents:
    """What the loop noticed since its last events, folded by kind (EventThrottle)."""

    def __init__(self, period: float) -> None:
        self.period = period
        self._overruns = EventThrottle()
        self._worst_lateness = 0.0  # s, since the last overrun event
        self._stalls = EventThrottle()
        self._longest_stall = 0.0  # s, since the last stall event
        self._rejected = EventThrottle()
        self._last_rejection: tuple[str, str] = ("", "")

    def overran(self, lateness: float) -> None:
        """A tick started `lateness` late or ended after the next deadline by as much."""
        self._overruns.hit()
        self._worst_lateness = max(self._worst_lateness, lateness)

    def stalled(self, lateness: float) -> None:
        """The loop woke `lateness` late; a stall if longer than STALL_S."""
        if lateness > STALL_S:
            self._stalls.hit()
            self._longest_stall = max(self._longest_stall, lateness)

    def rejected(self, count: int, verb: str, error: str) -> None:
        """`count` commands refused, the last one `verb` with `error`."""
        self._rejected.pending += count
        self._last_rejection = (verb[:64], error[:300])

    def due(self, now: float, t: float, overruns: int, skipped: int) -> list[dict[str, object]]:
        """The events to publish now, at sim time `t`; `overruns` and `skipped` are the loop's
        totals since start."""
        events: list[dict[str, object]] = []
        if count := self._overruns.take(now):
            worst, self._worst_lateness = self._worst_lateness * 1e6, 0.0
            events.append(
                {
                    "type": "overrun",
                    "t": t,
                    "message": f"{count} tick(s) overran the {self.period * 1e3:g} ms period",
                    "count": count,
                    "total": overruns,
                    "max_lateness_us": round(worst, 1),
                }
            )
        if count := self._stalls.take(now):
            longest, self._longest_stall = self._longest_stall, 0.0
            events.append(
                {
                    "type": "stall",
                    "t": t,
                    "message": f"the loop stood still for {longest:.2f} s (the process was "
                    "stopped or starved); the periods lost were skipped, not caught up",
                    "count": count,
                    "seconds": round(longest, 3),
                    "skipped": skipped,
                }
            )
        if count := self._rejected.take(now):
            verb, error = self._last_rejection
            events.append(
                {
                    "type": "rejected_command",
                    "t": t,
                    "message": f"{count} command(s) rejected; last: {error}",
                    "verb": verb,
                    "error": error,
                    "count": count,
                }
            )
        return events
