"""Edits of a task stack as plain data: levels in priority order, each a list of task names.

Every function returns a new list of levels and never mutates its input. Empty levels are dropped,
so the result is always a valid `stack` command payload. A name that is not in the stack raises
`ValueError` naming it.
"""

Levels = list[list[str]]


def find_task(levels: Levels, task: str) -> tuple[int, int]:
    """(level index, position in level) of `task`."""
    for i, level in enumerate(levels):
        if task in level:
            return i, level.index(task)
    raise ValueError(f"task {task!r} is not in the stack")


def _without(levels: Levels, task: str) -> Levels:
    return [[t for t in level if t != task] for level in levels]


def _compact(levels: Levels) -> Levels:
    return [level for level in levels if level]


def move_to_level_above(levels: Levels, task: str) -> Levels:
    """Move `task` into the level above its own (a new top level if it is already on top)."""
    i, _ = find_task(levels, task)
    if i == 0:
        return move_to_new_level(levels, task, above=True)
    out = _without(levels, task)
    out[i - 1].append(task)
    return _compact(out)


def move_to_level_below(levels: Levels, task: str) -> Levels:
    """Move `task` into the level below its own (a new bottom level if it is at the bottom)."""
    i, _ = find_task(levels, task)
    if i == len(levels) - 1:
        return move_to_new_level(levels, task, above=False)
    out = _without(levels, task)
    out[i + 1].append(task)
    return _compact(out)


def move_to_new_level(levels: Levels, task: str, *, above: bool) -> Levels:
    """Put `task` alone in a new level just above (or below) the level it is in now."""
    i, _ = find_task(levels, task)
    out = _without(levels, task)
    out.insert(i if above else i + 1, [task])
    return _compact(out)


def move_within_level(levels: Levels, task: str, step: int) -> Levels:
    """Shift `task` by `step` places inside its own level (clamped at the ends)."""
    i, j = find_task(levels, task)
    out = [list(level) for level in levels]
    level = out[i]
    level.pop(j)
    level.insert(max(0, min(len(level), j + step)), task)
    return out


def disable_task(levels: Levels, task: str) -> Levels:
    """Remove `task` from the stack (its level disappears if it was alone)."""
    find_task(levels, task)
    return _compact(_without(levels, task))


def enable_task(levels: Levels, task: str, level: int) -> Levels:
    """Insert `task` into level `level` (clamped; one past the last level makes a new bottom)."""
    if any(task in lvl for lvl in levels):
        raise ValueError(f"task {task!r} is already in the stack")
    out = [list(lvl) for lvl in levels]
    index = max(0, min(len(out), level))
    if index == len(out):
        out.append([task])
    else:
        out[index].append(task)
    return out
