"""Stack: plain data naming the tasks and constraints of each priority level, highest first.

The Newton–Euler rows of the dynamics are not in the stack: every hierarchy method keeps them as a
hard constraint above level 1 (Herzog §2.3–2.4).
"""

from collections.abc import Iterable, Sequence
from dataclasses import dataclass


class StackError(ValueError):
    """A stack that names an unknown task, repeats one, or has an empty level."""


@dataclass(frozen=True)
class Stack:
    """Levels of task and constraint names, highest priority first."""

    levels: tuple[tuple[str, ...], ...]

    @classmethod
    def of(cls, levels: Iterable[Sequence[str]]) -> "Stack":
        """A stack from any nested sequence of names (lists from JSON or TOML, say)."""
        return cls(tuple(tuple(level) for level in levels))

    def names(self) -> tuple[str, ...]:
        """Every name of the stack, level by level."""
        return tuple(name for level in self.levels for name in level)

    def validate(self, known: Iterable[str]) -> None:
        """Raise StackError naming the first problem: unknown or repeated name, empty level."""
        known = set(known)
        if not self.levels:
            raise StackError("the stack has no levels")
        seen: set[str] = set()
        for i, level in enumerate(self.levels, start=1):
            if not level:
                raise StackError(f"level {i} is empty")
            for name in level:
                if name not in known:
                    raise StackError(f"unknown task {name!r} (known: {', '.join(sorted(known))})")
                if name in seen:
                    raise StackError(f"task {name!r} appears twice")
                seen.add(name)

    def as_lists(self) -> list[list[str]]:
        """The levels as lists (JSON-ready)."""
        return [list(level) for level in self.levels]
