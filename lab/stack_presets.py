"""Named stacks from the papers, as data: `stacks/<name>.toml`.

A preset holds the priority levels (highest first), the hierarchy `method` it is meant for, and
the gains of its tasks. A scenario names one with `stack = "<name>"` in its `[controller]` table;
its own `method` and `[controller.gains.<task>]` entries override the preset's. The levels are an
ordinary stack afterwards, reorderable with the `stack` command.
"""

import tomllib
from dataclasses import dataclass

from lab.controller.tasks import TASK_TYPES
from lab.description import STACK_PRESET_NAMES as PRESET_NAMES
from lab.description import STACKS_DIR
from lab.protocol import CommandError, parse_command

PRESET_KEYS = {"description", "method", "levels", "gains"}
RENAMED_KEYS = {"hierarchy": "method"}  # old spelling -> the one word for the concept now


@dataclass(frozen=True)
class StackPreset:
    name: str
    description: str
    method: str  # hierarchy method: cascade | weighted | nullspace
    levels: list[list[str]]
    gains: dict[str, dict[str, float]]


def load_stack_preset(name: str) -> StackPreset:
    """Read `stacks/<name>.toml`; an unknown name raises KeyError naming the known presets, a
    malformed file ValueError naming the problem."""
    if name not in PRESET_NAMES:
        raise KeyError(f"unknown stack preset {name!r} (presets: {', '.join(PRESET_NAMES)})")
    path = STACKS_DIR / f"{name}.toml"
    data = tomllib.loads(path.read_text())
    for old, new in RENAMED_KEYS.items():
        if old in data:
            raise ValueError(f"{path}: key {old!r} is now called {new!r}")
    unknown = set(data) - PRESET_KEYS
    if unknown:
        raise ValueError(f"{path}: unknown keys {sorted(unknown)}")
    levels = data.get("levels")
    if not isinstance(levels, list) or not all(
        isinstance(level, list) and level and all(isinstance(n, str) for n in level)
        for level in levels
    ):
        raise ValueError(f"{path}: levels must be a list of non-empty lists of task names")
    return StackPreset(
        name=name,
        description=str(data.get("description", "")),
        method=str(data.get("method", "cascade")),
        levels=levels,
        gains=check_gains(data.get("gains", {}), f"{path}: [gains"),
    )


def check_gains(gains: object, where: str) -> dict[str, dict[str, float]]:
    """A table `{task: {kp, kd, weight}}` (a preset's `[gains]`, a scenario's
    `[controller.gains]`) checked as the `gains` command checks them, for tasks that exist.
    Raises ValueError naming `where` (`"<file>: [gains"`, closed here with `.<task>]`), the
    task and the field."""
    if not isinstance(gains, dict):
        raise ValueError(f"{where}]: must be a table of tasks, got {type(gains).__name__}")
    checked = {}
    for task, values in gains.items():
        if task not in TASK_TYPES:
            raise ValueError(f"{where}.{task}]: unknown task (tasks: {', '.join(TASK_TYPES)})")
        if not isinstance(values, dict) or "task" in values:
            raise ValueError(f"{where}.{task}]: must be a table of kp, kd and weight")
        try:
            command = parse_command("gains", {"task": task, **values})
        except CommandError as error:
            raise ValueError(f"{where}.{task}]: {str(error).removeprefix('gains: ')}") from None
        fields = {"kp": command.kp, "kd": command.kd, "weight": command.weight}
        checked[task] = {key: value for key, value in fields.items() if value is not None}
    return checked
