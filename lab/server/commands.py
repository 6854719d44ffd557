"""Parse and validate every lab command: a verb and a JSON object in, a frozen dataclass out.

The dataclasses (one per verb), the ranges and the key names are `lab.protocol`'s; this module
checks a payload against them.

Zenoh queries (`lab/cmd/<verb>`) and scenario `[[events]]` both go through `parse_command`, so a
scenario event has exactly the protocol's verb and fields. This module is pure: it checks shapes,
types and ranges only. Whether a name exists in the running session (robot, scene, task, link,
hierarchy method, solver, gait) is the session's business.
"""

import math
import re
from collections.abc import Callable, Mapping

from lab.protocol import (
    CYCLE_TIME_MAX,
    FLOOR_SECONDS_MAX,
    FLOOR_SECONDS_MIN,
    GAIN_MAX,
    NAME_MAX_LEN,
    POINT_COORD_MAX,
    PUSH_DURATION_MAX,
    PUSH_FORCE_MAX,
    RECORD_ACTIONS,
    STACK_MAX_LEVELS,
    STACK_MAX_TASKS,
    STEP_HEIGHT_MAX,
    SWING_HZ_MAX,
    VX_MAX,
    VY_MAX,
    WEIGHT_MAX,
    YAW_RATE_MAX,
    Command,
    FloorCommand,
    GainsCommand,
    GaitCommand,
    HierarchyCommand,
    InfoCommand,
    InternalForceCommand,
    MomentumCommand,
    PauseCommand,
    PushCommand,
    RecordCommand,
    ReleaseCommand,
    ResetCommand,
    ResumeCommand,
    RobotCommand,
    SceneCommand,
    StackCommand,
    StanceCommand,
    TakeCommand,
    VelocityCommand,
)

_NAME_RE = re.compile(r"[A-Za-z0-9_.:/-]+")
# verb -> {old field name: its name now}: an old spelling is rejected naming the new word
RENAMED_FIELDS: dict[str, dict[str, str]] = {"hierarchy": {"hierarchy": "method"}}


class CommandError(ValueError):
    """A command was rejected; the message names the verb, the field and what was wrong."""


class _Fields:
    """Typed accessors over one payload that raise CommandError naming verb and field."""

    def __init__(self, verb: str, payload: Mapping[str, object]) -> None:
        self.verb = verb
        self.payload = payload

    def error(self, field: str, what: str) -> CommandError:
        return CommandError(f"{self.verb}: field '{field}' {what}")

    def only(self, *allowed: str) -> None:
        for old, new in RENAMED_FIELDS.get(self.verb, {}).items():
            if old in self.payload:
                raise CommandError(f"{self.verb}: field {old!r} is now called {new!r}")
        unknown = sorted(k for k in self.payload if k not in allowed)
        if unknown:
            names = ", ".join(repr(k)[:NAME_MAX_LEN] for k in unknown[:5])
            expected = ", ".join(allowed) if allowed else "no fields"
            raise CommandError(f"{self.verb}: unknown field(s) {names} (expected {expected})")

    def has(self, field: str) -> bool:
        return field in self.payload

    def number(self, field: str, lo: float, hi: float, *, lo_open: bool = False) -> float:
        if field not in self.payload:
            raise self.error(field, "is missing")
        return self._number(field, self.payload[field], lo, hi, lo_open)

    def _number(self, field: str, raw: object, lo: float, hi: float, lo_open: bool) -> float:
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise self.error(field, f"must be a number, got {_type_name(raw)}")
        try:
            value = float(raw)
        except OverflowError:
            raise self.error(field, f"is out of range [{lo:g}, {hi:g}]") from None
        if not math.isfinite(value):
            raise self.error(field, f"must be finite, got {value}")
        if value > hi or value < lo or (lo_open and value == lo):
            bracket = "(" if lo_open else "["
            raise self.error(field, f"= {value:g} is out of range {bracket}{lo:g}, {hi:g}]")
        return value

    def vector3(self, field: str, coord_max: float) -> tuple[float, float, float]:
        if field not in self.payload:
            raise self.error(field, "is missing")
        raw = self.payload[field]
        if not isinstance(raw, list | tuple) or len(raw) != 3:
            raise self.error(field, f"must be a list of 3 numbers, got {_type_name(raw)}")
        x, y, z = (
            self._number(f"{field}[{i}]", c, -coord_max, coord_max, False)
            for i, c in enumerate(raw)
        )
        return (x, y, z)

    def name(self, field: str) -> str:
        if field not in self.payload:
            raise self.error(field, "is missing")
        return self._name(field, self.payload[field])

    def _name(self, field: str, raw: object) -> str:
        if not isinstance(raw, str):
            raise self.error(field, f"must be a string, got {_type_name(raw)}")
        if not raw:
            raise self.error(field, "must not be empty")
        if len(raw) > NAME_MAX_LEN:
            raise self.error(field, f"is longer than {NAME_MAX_LEN} characters")
        if not _NAME_RE.fullmatch(raw):
            raise self.error(field, f"{raw!r} may only contain letters, digits and _ . : / -")
        return raw


def _type_name(value: object) -> str:
    return "null" if value is None else type(value).__name__


def _no_fields(cls: type) -> Callable[[_Fields], Command]:
    def parse(f: _Fields) -> Command:
        f.only()
        return cls()

    return parse


def _velocity(f: _Fields) -> VelocityCommand:
    f.only("vx", "vy", "yaw_rate")
    limits = {"vx": VX_MAX, "vy": VY_MAX, "yaw_rate": YAW_RATE_MAX}
    values = {k: f.number(k, -m, m) for k, m in limits.items() if f.has(k)}
    return VelocityCommand(**values)


def _push(f: _Fields) -> PushCommand:
    f.only("body", "force", "duration", "point")
    body = f.name("body")
    force = f.vector3("force", PUSH_FORCE_MAX)
    norm = math.hypot(*force)
    if norm > PUSH_FORCE_MAX:
        raise f.error("force", f"norm {norm:g} N exceeds {PUSH_FORCE_MAX:g} N")
    duration = f.number("duration", 0.0, PUSH_DURATION_MAX, lo_open=True)
    point = f.vector3("point", POINT_COORD_MAX) if f.has("point") else None
    return PushCommand(body=body, force=force, duration=duration, point=point)


def _robot(f: _Fields) -> RobotCommand:
    f.only("name")
    return RobotCommand(name=f.name("name"))


def _scene(f: _Fields) -> SceneCommand:
    f.only("name")
    return SceneCommand(name=f.name("name"))


def _gait(f: _Fields) -> GaitCommand:
    f.only("name", "step_height", "cycle_time", "footholds")
    return GaitCommand(
        name=f.name("name"),
        step_height=(
            f.number("step_height", 0.0, STEP_HEIGHT_MAX, lo_open=True)
            if f.has("step_height")
            else None
        ),
        cycle_time=(
            f.number("cycle_time", 0.0, CYCLE_TIME_MAX, lo_open=True)
            if f.has("cycle_time")
            else None
        ),
        footholds=f.name("footholds") if f.has("footholds") else None,
    )


def _hierarchy(f: _Fields) -> HierarchyCommand:
    f.only("method", "solver", "formulation", "kernel")
    method, solver, formulation, kernel = (
        f.name(key) if f.has(key) else None for key in ("method", "solver", "formulation", "kernel")
    )
    if method is None and kernel is None:
        raise f.error("method", "is missing (give a method, a kernel or both)")
    return HierarchyCommand(method=method, solver=solver, formulation=formulation, kernel=kernel)


def _stack(f: _Fields) -> StackCommand:
    f.only("levels", "preset")
    if f.has("preset"):
        if f.has("levels"):
            raise CommandError("stack: give either 'levels' or 'preset', not both")
        return StackCommand(preset=f.name("preset"))
    if not f.has("levels"):
        raise f.error("levels", "is missing")
    raw = f.payload["levels"]
    if not isinstance(raw, list | tuple) or not raw:
        raise f.error("levels", f"must be a non-empty list of lists, got {_type_name(raw)}")
    if len(raw) > STACK_MAX_LEVELS:
        raise f.error("levels", f"has more than {STACK_MAX_LEVELS} levels")
    levels: list[tuple[str, ...]] = []
    seen: set[str] = set()
    for i, level in enumerate(raw):
        field = f"levels[{i}]"
        if not isinstance(level, list | tuple) or not level:
            raise f.error(field, f"must be a non-empty list of task names, got {_type_name(level)}")
        if len(seen) + len(level) > STACK_MAX_TASKS:
            raise f.error("levels", f"has more than {STACK_MAX_TASKS} tasks")
        names = tuple(f._name(f"{field}[{j}]", name) for j, name in enumerate(level))
        for name in names:
            if name in seen:
                raise f.error(field, f"repeats task {name!r}")
            seen.add(name)
        levels.append(names)
    return StackCommand(levels=tuple(levels))


def _gains(f: _Fields) -> GainsCommand:
    f.only("task", "kp", "kd", "weight")
    task = f.name("task")
    kp = f.number("kp", 0.0, GAIN_MAX) if f.has("kp") else None
    kd = f.number("kd", 0.0, GAIN_MAX) if f.has("kd") else None
    weight = f.number("weight", 0.0, WEIGHT_MAX, lo_open=True) if f.has("weight") else None
    if kp is None and kd is None and weight is None:
        raise CommandError("gains: give at least one of 'kp', 'kd', 'weight'")
    return GainsCommand(task=task, kp=kp, kd=kd, weight=weight)


def _momentum(f: _Fields) -> MomentumCommand:
    f.only("mode")
    return MomentumCommand(mode=f.name("mode"))


def _record(f: _Fields) -> RecordCommand:
    f.only("action")
    action = f.name("action")
    if action not in RECORD_ACTIONS:
        known = ", ".join(RECORD_ACTIONS)
        raise CommandError(f"record: action must be one of {known}, got {action!r}")
    return RecordCommand(action=action)


def _internal_force(f: _Fields) -> InternalForceCommand:
    f.only("reference", "source")
    reference = (
        f.number("reference", -PUSH_FORCE_MAX, PUSH_FORCE_MAX) if f.has("reference") else None
    )
    source = f.name("source") if f.has("source") else None
    if reference is None and source is None:
        raise CommandError("internal_force: give at least one of 'reference', 'source'")
    return InternalForceCommand(reference=reference, source=source)


def _floor(f: _Fields) -> FloorCommand:
    f.only("seconds")
    if not f.has("seconds"):
        return FloorCommand()
    return FloorCommand(seconds=f.number("seconds", FLOOR_SECONDS_MIN, FLOOR_SECONDS_MAX))


def _stance(f: _Fields) -> StanceCommand:
    f.only("side", "swing")
    if not f.has("side") and not f.has("swing"):
        raise CommandError("stance: give a 'side', a 'swing' frequency or both")
    swing = f.number("swing", 0.0, SWING_HZ_MAX) if f.has("swing") else None
    return StanceCommand(side=f.name("side") if f.has("side") else None, swing=swing)


_PARSERS: dict[str, Callable[[_Fields], Command]] = {
    "info": _no_fields(InfoCommand),
    "velocity": _velocity,
    "push": _push,
    "robot": _robot,
    "scene": _scene,
    "hierarchy": _hierarchy,
    "stack": _stack,
    "gains": _gains,
    "reset": _no_fields(ResetCommand),
    "pause": _no_fields(PauseCommand),
    "resume": _no_fields(ResumeCommand),
    "gait": _gait,
    "momentum": _momentum,
    "record": _record,
    "internal_force": _internal_force,
    "stance": _stance,
    "take": _no_fields(TakeCommand),
    "release": _no_fields(ReleaseCommand),
    "floor": _floor,
}

VERBS: tuple[str, ...] = tuple(_PARSERS)


def parse_command(verb: str, payload: object) -> Command:
    """Validate `payload` (a decoded JSON object) for `verb`; raise CommandError if it is wrong."""
    if not isinstance(verb, str) or verb not in _PARSERS:
        shown = verb[:NAME_MAX_LEN] if isinstance(verb, str) else repr(verb)[:NAME_MAX_LEN]
        raise CommandError(f"{shown}: unknown command (known: {', '.join(VERBS)})")
    if not isinstance(payload, Mapping):
        raise CommandError(f"{verb}: payload must be a JSON object, got {_type_name(payload)}")
    bad_keys = [k for k in payload if not isinstance(k, str)]
    if bad_keys:
        raise CommandError(f"{verb}: field names must be strings, got {bad_keys[0]!r}"[:200])
    return _PARSERS[verb](_Fields(verb, payload))
