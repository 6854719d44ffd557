"""A command's payload validated into its struct in one step (msgspec), with msgspec's error
turned into the lab's: `<verb>: field '<field>' <what was wrong>`.

Zenoh queries (after the intake decoded the JSON) and scenario `[[events]]` both go through
`parse_command`, so a scenario event has exactly the protocol's verb and fields.
"""

import math
import re
from collections.abc import Mapping
from typing import TypeVar

import msgspec
from msgspec import inspect

from lab.protocol.commands import (
    COMMANDS,
    NAME_MAX_LEN,
    REPLAY_COMMANDS,
    VERBS,
    Command,
    CommandStruct,
    ReplayCommand,
)

# verb -> {old field name: its name now}: an old spelling is rejected naming the new word
RENAMED_FIELDS: dict[str, dict[str, str]] = {"hierarchy": {"hierarchy": "method"}}
ERROR_MAX_LEN = 300  # characters of an error message (a long name is cut)

_ERROR = re.compile(r"^(?P<what>.*?)(?: - at `\$(?P<path>[^`]*)`)?$", re.S)
_STEP = re.compile(r"\.(\w+)|\[(\d+)\]")
_JSON_TYPES = {"array": "list", "object": "dict"}  # msgspec's JSON names, as the lab says them
_EXPECTED = {"float": "a number", "str": "a string", "array": "a list", "object": "an object"}
_MISSING = object()
RANGE = "Number out of range"


class CommandError(ValueError):
    """A command was rejected; the message names the verb, the field and what was wrong."""


def parse_command(verb: str, payload: object) -> Command:
    """Validate `payload` (a decoded JSON object) for `verb` into its struct; raise
    CommandError naming the verb, the field and what was wrong."""
    if not isinstance(verb, str) or verb not in COMMANDS:
        shown = verb[:NAME_MAX_LEN] if isinstance(verb, str) else repr(verb)[:NAME_MAX_LEN]
        raise CommandError(f"{shown}: unknown command (known: {', '.join(VERBS)})")
    if isinstance(payload, Mapping):
        for old, new in RENAMED_FIELDS.get(verb, {}).items():
            if old in payload:
                raise CommandError(f"{verb}: field {old!r} is now called {new!r}")
    command: Command = _convert(verb, payload, COMMANDS[verb])  # type: ignore[assignment]
    return command


def parse_replay_command(verb: str, payload: object) -> ReplayCommand:
    """Validate `payload` for `verb` into its struct as a served recording takes it
    (`REPLAY_COMMANDS`: its playback's verbs); raise CommandError naming the verb, the field and
    what was wrong, or that a recording is read-only for any other verb."""
    if not isinstance(verb, str) or verb not in REPLAY_COMMANDS:
        shown = verb[:NAME_MAX_LEN] if isinstance(verb, str) else repr(verb)[:NAME_MAX_LEN]
        known = ", ".join(REPLAY_COMMANDS)
        raise CommandError(f"{shown}: a recording is read-only (replay commands: {known})")
    command: ReplayCommand = _convert(verb, payload, REPLAY_COMMANDS[verb])  # type: ignore[assignment]
    return command


def _convert(verb: str, payload: object, cls: type[CommandStruct]) -> CommandStruct:
    """`payload` validated into struct `cls` (msgspec, one step); CommandError otherwise."""
    if isinstance(payload, Mapping):  # an optional field is left out, never null
        for key, value in payload.items():
            if value is None and key in cls.__struct_fields__:
                raise CommandError(f"{verb}: field '{key}' must be {_expected(cls, key)}, got null")
    try:
        return msgspec.convert(payload, cls)
    except msgspec.ValidationError as error:
        raise CommandError(
            f"{verb}: {_explain(cls, payload, str(error))}"[:ERROR_MAX_LEN]
        ) from None


def _explain(cls: type, payload: object, error: str) -> str:
    """msgspec's `error` about `payload` (for struct `cls`) in the lab's words."""
    match = _ERROR.match(error)
    assert match is not None  # the pattern matches any text
    what, path = match["what"], match["path"]
    if "at `key` in" in error:
        return "field names must be strings"
    if path is None:  # the payload as a whole, or a check of the struct's own (__post_init__)
        if found := re.fullmatch(r"Object missing required field `(\w+)`", what):
            return f"field '{found[1]}' is missing"
        if found := re.fullmatch(r"Object contains unknown field `(.*)`", what):
            expected = ", ".join(inspect_fields(cls)) or "no fields"
            return f"unknown field(s) {found[1][:NAME_MAX_LEN]!r} (expected {expected})"
        if found := re.fullmatch(r"Expected `object`, got `(\w+)`", what):
            return f"payload must be a JSON object, got {_JSON_TYPES.get(found[1], found[1])}"
        return what
    field = path.lstrip(".")
    value = _value_at(payload, path)
    if found := re.fullmatch(r"Expected `(\w+)(?: \| null)?`, got `(\w+)`", what):
        expected = _EXPECTED.get(found[1], found[1])
        return f"field '{field}' must be {expected}, got {_JSON_TYPES.get(found[2], found[2])}"
    if what.startswith("Expected `float`") or what == RANGE:
        if isinstance(value, float) and not math.isfinite(value):
            return f"field '{field}' must be finite, got {value}"
        # "Number out of range": an integer too large for a float (no value worth printing)
        shown = f" = {value:g}" if isinstance(value, int | float) and what != RANGE else ""
        return f"field '{field}'{shown} is out of range {_range(cls, path)}"
    if found := re.fullmatch(r"Expected `array` of length (\d+), got (\d+)", what):
        return f"field '{field}' must be a list of {found[1]} numbers, got {found[2]} items"
    if what == "Expected `array` of length >= 1":
        return f"field '{field}' must be a non-empty list, got an empty one"
    if found := re.fullmatch(r"Expected `array` of length <= (\d+)", what):
        return f"field '{field}' has more than {found[1]} items"
    if what == "Expected `str` of length >= 1":
        return f"field '{field}' must not be empty"
    if found := re.fullmatch(r"Expected `str` of length <= (\d+)", what):
        return f"field '{field}' is longer than {found[1]} characters"
    if what.startswith("Expected `str` matching regex"):
        shown = repr(value)[:NAME_MAX_LEN]
        return f"field '{field}' {shown} may only contain letters, digits and _ . : / -"
    if what.startswith("Invalid enum value"):
        choices = ", ".join(str(v) for v in _type_at(cls, path, inspect.LiteralType).values)
        return f"field '{field}' must be one of {choices}, got {value!r}"
    return f"field '{field}': {what}"


def _expected(cls: type, field: str) -> str:
    """What field `field` of struct `cls` takes, in words."""
    node = _type_at(cls, f".{field}", inspect.Type)
    if isinstance(node, inspect.LiteralType):
        return "one of " + ", ".join(str(v) for v in node.values)
    words = {inspect.FloatType: "a number", inspect.StrType: "a string"}
    return words.get(type(node), "a list")


def inspect_fields(cls: type) -> list[str]:
    """The field names of struct `cls`, in order."""
    info = inspect.type_info(cls)
    assert isinstance(info, inspect.StructType)
    return [field.encode_name for field in info.fields]


def _steps(path: str) -> list[str | int]:
    return [name if name else int(index) for name, index in _STEP.findall(path)]


def _value_at(payload: object, path: str) -> object:
    """The value of `payload` at msgspec's `path` (`.force[2]`), or _MISSING."""
    value = payload
    for step in _steps(path):
        try:
            value = value[step]  # type: ignore[index]
        except (KeyError, IndexError, TypeError):
            return _MISSING
    return value


_T = TypeVar("_T", bound=inspect.Type)


def _type_at(cls: type, path: str, kind: type[_T]) -> _T:
    """The msgspec type of the field at `path` of struct `cls` that is of `kind` (a field that
    may be null is a union: its member of `kind`)."""
    node = _plain(inspect.type_info(cls), kind)
    for step in _steps(path):
        if isinstance(node, inspect.StructType):
            node = next(f.type for f in node.fields if f.encode_name == step)
        elif isinstance(node, inspect.TupleType):
            assert isinstance(step, int)
            node = node.item_types[step]
        elif isinstance(node, inspect.VarTupleType):
            node = node.item_type
        node = _plain(node, kind)
    assert isinstance(node, kind), (path, node)
    return node


def _plain(node: inspect.Type, kind: type[inspect.Type]) -> inspect.Type:
    """`node` without its metadata (description, constraints on a wrapper), and of a union
    (a field that may be null) the member of `kind`, else the one that is not null."""
    while isinstance(node, inspect.Metadata):
        node = node.type
    if isinstance(node, inspect.UnionType):
        members = [_plain(t, kind) for t in node.types]
        node = next(
            (t for t in members if isinstance(t, kind)),
            next(t for t in members if not isinstance(t, inspect.NoneType)),
        )
    return node


def _range(cls: type, path: str) -> str:
    """`[lo, hi]` or `(lo, hi]` of the number field at `path`."""
    number = _type_at(cls, path, inspect.FloatType)
    low, bracket = (number.gt, "(") if number.gt is not None else (number.ge, "[")
    return f"{bracket}{low:g}, {number.le:g}]"
