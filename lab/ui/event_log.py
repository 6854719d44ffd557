"""The page's event log: timestamped falls, resets, rejected commands, clamped or refused numbers,
solver fallbacks and UI errors, newest first (pure: the app renders `markdown()` in the page)."""

import time
from collections import deque
from dataclasses import dataclass

LEVEL_MARKS = {"info": "·", "warning": "⚠", "error": "✖"}


@dataclass(frozen=True)
class LogEntry:
    """One line of the log: wall-clock time (s since the epoch), level and text."""

    wall: float
    level: str
    text: str


class EventLog:
    """The last `size` entries. An entry equal to the newest one bumps its count instead; an
    entry of a `kind` already in the log (a status warning that comes and goes, such as "the sim
    runs behind real time") replaces that entry and bumps its count, so a flapping warning
    takes one line however often it starts, and never pushes the other events out."""

    def __init__(self, size: int = 40) -> None:
        self._entries: deque[tuple[LogEntry, int, str | None]] = deque(maxlen=size)
        self.version = 0  # changes whenever the log does: the app redraws then

    def add(
        self, level: str, text: str, wall: float | None = None, kind: str | None = None
    ) -> LogEntry:
        """Log `text` at `level` (now, or at `wall`); `kind` names a recurring warning."""
        if level not in LEVEL_MARKS:
            raise ValueError(f"log level {level!r} is not one of {', '.join(LEVEL_MARKS)}")
        entry = LogEntry(time.time() if wall is None else wall, level, text)
        same = [
            i
            for i, (old, _, old_kind) in enumerate(self._entries)
            if (kind is not None and old_kind == kind)
            or (i == 0 and (old.level, old.text) == (level, text))
        ]
        count = 1
        if same:
            count += self._entries[same[0]][1]
            del self._entries[same[0]]
        self._entries.appendleft((entry, count, kind))
        self.version += 1
        return entry

    def entries(self) -> list[LogEntry]:
        """Newest first."""
        return [entry for entry, _, _ in self._entries]

    def markdown(self) -> str:
        if not self._entries:
            return "Events, newest first: none yet."
        lines = ["Events, newest first:", ""]
        for entry, count, _ in self._entries:
            stamp = time.strftime("%H:%M:%S", time.localtime(entry.wall))
            repeat = f" (×{count})" if count > 1 else ""
            text = entry.text.replace("\n", " ")
            lines.append(f"- `{stamp}` {LEVEL_MARKS[entry.level]} {text}{repeat}")
        return "\n".join(lines)
