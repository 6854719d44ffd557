"""The page's event log (pure: the app renders `markdown()` in the page; tests/ui/test_ui_logic.py).

Two parts:
- **Recurring** lines, one per kind of event that repeats by nature (the loop's overruns): a
  count and a rate, updated in place, always shown at the top. Overruns came every second and,
  as separate lines, pushed everything else out of the 40 lines kept within 40 s.
- **Events**, newest first, kept for the whole session (up to KEPT, far beyond any session a
  user watches): pushes, refusals, falls, resets, faults, status warnings, the rest. Each has a
  category, and `markdown(category)` shows only one. A line equal to the newest one bumps its
  count; a status warning that comes and goes (`kind`) keeps one line, moved to the top with
  its count each time it starts again.

Callbacks of several browsers (viser's thread pool) and the render loop add and render at once:
a lock keeps the log whole (the render loop read "deque mutated during iteration").
"""

import threading
import time
from collections import deque
from dataclasses import dataclass, field

LEVEL_MARKS = {"info": "·", "warning": "⚠", "error": "✖"}
# What the log's filter offers, in this order ("all" shows every category).
CATEGORIES = ("push", "refusal", "fall", "reset", "fault", "warning", "info")
ALL = "all"
KEPT = 5000  # events kept (a session's pushes and falls; memory stays bounded)
SHOWN = 40  # lines shown, newest first
RATE_WINDOW_S = 10.0  # a recurring line's rate is over this much wall time


@dataclass(frozen=True)
class LogEntry:
    """One line of the log: wall-clock time (s since the epoch), level, text and category."""

    wall: float
    level: str
    text: str
    category: str = "info"


@dataclass
class _Kept:
    entry: LogEntry
    count: int
    kind: str | None


@dataclass
class Recurring:
    """A kind of event that repeats, as one line: how many, since when, how often lately."""

    name: str
    level: str
    text: str  # the newest event's own text
    first: float  # wall s
    count: int = 0  # units counted (e.g. ticks that overran), over the session
    events: int = 0
    recent: deque = field(default_factory=deque)  # (wall s, count) of the last RATE_WINDOW_S

    def add(self, wall: float, count: int, text: str) -> None:
        self.count += count
        self.events += 1
        self.text = text
        self.recent.append((wall, count))
        while self.recent and self.recent[0][0] <= wall - RATE_WINDOW_S:
            self.recent.popleft()

    def rate(self, now: float) -> float:
        """Counted units per second over the last RATE_WINDOW_S (0 once they stopped)."""
        return sum(n for wall, n in self.recent if wall > now - RATE_WINDOW_S) / RATE_WINDOW_S

    def line(self, now: float) -> str:
        since = time.strftime("%H:%M:%S", time.localtime(self.first))
        return (
            f"{LEVEL_MARKS[self.level]} **{self.name}**: {self.count:,} since {since} "
            f"({self.events:,} reports) · {self.rate(now):.1f}/s over the last "
            f"{RATE_WINDOW_S:g} s · last: {self.text}"
        )


class EventLog:
    """The session's events and recurring lines (see the module docstring)."""

    def __init__(self, size: int = KEPT) -> None:
        self._entries: deque[_Kept] = deque(maxlen=size)
        self._recurring: dict[str, Recurring] = {}
        self._lock = threading.Lock()
        self.version = 0  # changes whenever the log does: the app redraws then

    def add(
        self,
        level: str,
        text: str,
        wall: float | None = None,
        kind: str | None = None,
        category: str | None = None,
    ) -> LogEntry:
        """Log `text` at `level` (now, or at `wall`) in `category` (default: `info`, or
        `warning` for a status warning `kind`); `kind` names a warning that comes and goes."""
        if level not in LEVEL_MARKS:
            raise ValueError(f"log level {level!r} is not one of {', '.join(LEVEL_MARKS)}")
        category = category or ("warning" if kind is not None else "info")
        if category not in CATEGORIES:
            raise ValueError(f"log category {category!r} is not one of {', '.join(CATEGORIES)}")
        entry = LogEntry(time.time() if wall is None else wall, level, text, category)
        with self._lock:
            same = [
                i
                for i, old in enumerate(self._entries)
                if (kind is not None and old.kind == kind)
                or (i == 0 and (old.entry.level, old.entry.text) == (level, text))
            ]
            count = 1
            if same:
                count += self._entries[same[0]].count
                del self._entries[same[0]]
            self._entries.appendleft(_Kept(entry, count, kind))
            self.version += 1
        return entry

    def recur(
        self, name: str, count: int, text: str, level: str = "warning", wall: float | None = None
    ) -> Recurring:
        """Count `count` more of recurring `name` (e.g. ticks that overran) on its one line."""
        now = time.time() if wall is None else wall
        with self._lock:
            line = self._recurring.setdefault(name, Recurring(name, level, text, now))
            line.add(now, count, text)
            self.version += 1
            return line

    def entries(self, category: str = ALL) -> list[LogEntry]:
        """Newest first, of `category` (or all)."""
        with self._lock:
            return [k.entry for k in self._entries if category in (ALL, k.entry.category)]

    def recurring(self) -> list[Recurring]:
        with self._lock:
            return list(self._recurring.values())

    def markdown(self, category: str = ALL, now: float | None = None) -> str:
        """The recurring lines, then the newest SHOWN events of `category` (or all)."""
        now = time.time() if now is None else now
        with self._lock:
            recurring = [line.line(now) for line in self._recurring.values()]
            kept = [k for k in self._entries if category in (ALL, k.entry.category)]
        lines = [f"- {line}" for line in recurring]
        if lines:
            lines.append("")
        which = "" if category == ALL else f" ({category})"
        if not kept:
            return "\n".join([*lines, f"Events{which}, newest first: none yet."])
        lines += [f"Events{which}, newest first ({len(kept)} kept):", ""]
        for k in kept[:SHOWN]:
            stamp = time.strftime("%H:%M:%S", time.localtime(k.entry.wall))
            repeat = f" (×{k.count})" if k.count > 1 else ""
            text = k.entry.text.replace("\n", " ")
            lines.append(f"- `{stamp}` {LEVEL_MARKS[k.entry.level]} {text}{repeat}")
        return "\n".join(lines)


# The server's events (`lab/<id>/events`, lab.protocol.events) by the log's category and level;
# any other kind is logged as an info warning (tests/protocol/test_protocol_messages.py: only kinds
# the
# server sends are named here).
SERVER_EVENTS = {
    "fall": ("fall", "error"),
    "reset": ("reset", "info"),
    "session_rebuilt": ("reset", "info"),
    "rejected_command": ("refusal", "error"),
    "solver_failure": ("fault", "error"),
    "solver_fallback": ("fault", "warning"),
    "solver_capped": ("fault", "warning"),
    "solver_violation": ("fault", "warning"),
    "sim_diverged": ("fault", "error"),
    "stall": ("fault", "warning"),
}
RECURRING_EVENTS = {"overrun": "count"}  # server events counted on one line, by their field


def log_server_event(log: EventLog, event: dict, wall: float | None = None) -> None:
    """One server event into `log` (received at `wall`, default now): a recurring one onto its
    line, any other as an entry."""
    kind = event.get("type", "?")
    message = event.get("message", kind)
    stamp = f"t {event.get('t', float('nan')):.2f} s"
    if kind in RECURRING_EVENTS:
        count = event.get(RECURRING_EVENTS[kind], 1)
        count = int(count) if isinstance(count, int | float) else 1
        log.recur(kind, count, f"{stamp}: {message}", wall=wall)
        return
    category, level = SERVER_EVENTS.get(kind, ("info", "warning"))
    log.add(level, f"{stamp} · {kind}: {message}", wall=wall, category=category)
