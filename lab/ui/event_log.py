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
    """The last `size` entries; an entry equal to the newest one bumps its count instead."""

    def __init__(self, size: int = 40) -> None:
        self._entries: deque[tuple[LogEntry, int]] = deque(maxlen=size)
        self.version = 0  # changes whenever the log does: the app redraws then

    def add(self, level: str, text: str, wall: float | None = None) -> LogEntry:
        if level not in LEVEL_MARKS:
            raise ValueError(f"log level {level!r} is not one of {', '.join(LEVEL_MARKS)}")
        entry = LogEntry(time.time() if wall is None else wall, level, text)
        if self._entries and (self._entries[0][0].level, self._entries[0][0].text) == (
            level,
            text,
        ):
            self._entries[0] = (entry, self._entries[0][1] + 1)
        else:
            self._entries.appendleft((entry, 1))
        self.version += 1
        return entry

    def entries(self) -> list[LogEntry]:
        """Newest first."""
        return [entry for entry, _ in self._entries]

    def markdown(self) -> str:
        if not self._entries:
            return "Events, newest first: none yet."
        lines = ["Events, newest first:", ""]
        for entry, count in self._entries:
            stamp = time.strftime("%H:%M:%S", time.localtime(entry.wall))
            repeat = f" (×{count})" if count > 1 else ""
            text = entry.text.replace("\n", " ")
            lines.append(f"- `{stamp}` {LEVEL_MARKS[entry.level]} {text}{repeat}")
        return "\n".join(lines)
