"""Sweep files: a base scenario and the fields to vary, expanded into points.

A sweep file names a `base` scenario (a path relative to the sweep file) and how to vary it:

    name = "anymal_push_map"
    base = "../scenarios/anymal_push_lateral.toml"
    duration = 3.0           # optional: shortens every point's run
    timeout = 300            # optional: s of wall time a point may take before it is an error row

    [set]                    # optional: fields every point gets
    metrics = ["cog_tracking"]

    [grid]                   # every combination of these values
    "controller.method" = ["cascade", "weighted", "nullspace"]
    "push.force_n" = [100, 200, 300]

    [sample]                 # optional: n random draws (seeded), crossed with the grid
    n = 20
    seed = 0
    "push.direction_deg" = { uniform = [0.0, 360.0] }
    "controller.kernel" = { choice = ["native", "python"] }

    [[points]]               # optional: single points added as they are
    robot = "solo12"

A field is a dotted path into the scenario's TOML (`robot`, `scene`, `duration`, `metrics`,
`controller.method`, `controller.kernel`, `controller.stack`, `controller.gains.<task>.kp`, ...)
or `<verb>.<field>` of the base scenario's one event with that protocol verb (`push.duration`,
`push.body`, `velocity.vx`, `gait.name`; `<verb>.t` is the event's time). Two fields are
derived from a push's force vector: `push.force_n` (its magnitude, direction kept) and
`push.direction_deg` (its horizontal direction, degrees about z from +x, magnitude kept).
"""

import copy
import itertools
import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.experiments.scenario import SCENARIO_KEYS, Scenario, ScenarioError, parse_scenario
from lab.protocol import VERBS

SWEEP_KEYS = {"name", "description", "base", "duration", "timeout", "set", "grid", "sample"}
SWEEP_KEYS |= {"points"}
DEFAULT_TIMEOUT = 600.0  # s of wall time per point
DERIVED_PUSH_FIELDS = ("push.force_n", "push.direction_deg")


class SweepError(ValueError):
    """A sweep file that is not well formed, or a field that does not fit its base scenario."""


@dataclass(frozen=True)
class Point:
    """One scenario of a sweep: the varied fields' values, and the scenario TOML they give."""

    fields: dict[str, object]
    scenario: dict

    @property
    def key(self) -> str:
        """The point's identity in a results table (its field values as sorted JSON)."""
        return point_key(self.fields)


@dataclass
class Sweep:
    """A parsed sweep file: its points in order and the wall time allowed to each."""

    name: str
    base: Path
    points: list[Point] = field(default_factory=list)
    fields: list[str] = field(default_factory=list)  # every varied field, in file order
    timeout: float = DEFAULT_TIMEOUT


def point_key(fields: dict[str, object]) -> str:
    """A point's identity: its fields as JSON with sorted keys."""
    return json.dumps(fields, sort_keys=True)


def load_sweep(path: str | Path) -> Sweep:
    """Read a sweep file and expand it; every point's scenario is checked as `lab run` would."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise SweepError(f"{path}: {error}") from error
    unknown = set(data) - SWEEP_KEYS
    if unknown:
        raise SweepError(f"{path}: unknown keys {sorted(unknown)}")
    if "base" not in data:
        raise SweepError(f"{path}: needs `base`, the path of the scenario to vary")
    base = (path.parent / data["base"]).resolve()
    try:
        base_data = tomllib.loads(base.read_text())
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise SweepError(f"{path}: base scenario: {error}") from error
    # A point changes the scenario (its duration too): the base's [expect] is not the point's.
    base_data.pop("expect", None)
    if "duration" in data:
        base_data["duration"] = data["duration"]
    for name, value in data.get("set", {}).items():
        _apply(base_data, name, value, f"{path}: [set]")
    combos = _expand(path, data)
    sweep = Sweep(data.get("name", path.stem), base, timeout=_timeout(path, data))
    sweep.fields = list(dict.fromkeys(name for combo in combos for name in combo))
    for combo in combos:
        scenario = copy.deepcopy(base_data)
        for key, value in combo.items():
            _apply(scenario, key, value, f"{path}: point {point_key(combo)}")
        scenario["name"] = sweep.name  # not the base's name: a point may change what it says
        check_scenario(scenario, base)
        sweep.points.append(Point(combo, scenario))
    keys = [p.key for p in sweep.points]
    if len(set(keys)) != len(keys):
        raise SweepError(f"{path}: some points are the same point twice")
    return sweep


def check_scenario(data: dict, base: Path) -> Scenario:
    """The scenario of a point's TOML, or SweepError saying what is wrong with it."""
    try:
        return parse_scenario(copy.deepcopy(data), base)
    except ScenarioError as error:
        raise SweepError(str(error)) from error


def _timeout(path: Path, data: dict) -> float:
    timeout = data.get("timeout", DEFAULT_TIMEOUT)
    if not isinstance(timeout, int | float) or not timeout > 0:
        raise SweepError(f"{path}: timeout must be a positive number of seconds")
    return float(timeout)


def _expand(path: Path, data: dict) -> list[dict[str, object]]:
    """The points' field values: grid × samples, then the explicit points."""
    grid = data.get("grid", {})
    for name, values in grid.items():
        if not isinstance(values, list) or not values:
            raise SweepError(f"{path}: [grid] {name!r} must be a non-empty list of values")
    combos = [dict(zip(grid, values, strict=True)) for values in itertools.product(*grid.values())]
    if "sample" in data:
        samples = _samples(path, data["sample"])
        combos = [{**combo, **sample} for combo in combos for sample in samples]
    explicit = data.get("points", [])
    if not isinstance(explicit, list) or not all(isinstance(p, dict) for p in explicit):
        raise SweepError(f"{path}: [[points]] must be tables of field = value")
    combos = [c for c in combos if c] + [dict(p) for p in explicit]
    if not combos:
        raise SweepError(f"{path}: no points: give a [grid], a [sample] or [[points]]")
    return combos


def _samples(path: Path, table: dict) -> list[dict[str, object]]:
    """`n` draws of the [sample] fields, each `{uniform = [low, high]}` or `{choice = [...]}`."""
    n, seed = table.get("n"), table.get("seed", 0)
    if not isinstance(n, int) or n < 1:
        raise SweepError(f"{path}: [sample] needs n, a positive number of points")
    rng = np.random.default_rng(seed)
    columns: dict[str, list[object]] = {}
    for name, law in table.items():
        if name in ("n", "seed"):
            continue
        if isinstance(law, dict) and set(law) == {"uniform"} and len(law["uniform"]) == 2:
            low, high = (float(x) for x in law["uniform"])
            columns[name] = [round(float(x), 6) for x in rng.uniform(low, high, n)]
        elif isinstance(law, dict) and set(law) == {"choice"} and law["choice"]:
            options = law["choice"]
            columns[name] = [options[i] for i in rng.integers(0, len(options), n)]
        else:
            raise SweepError(
                f"{path}: [sample] {name!r} must be {{uniform = [low, high]}} or "
                "{choice = [values]}"
            )
    return [{name: values[i] for name, values in columns.items()} for i in range(n)]


def _apply(scenario: dict, name: str, value: object, where: str) -> None:
    """Set field `name` of a scenario's TOML data to `value` (see the module docstring)."""
    head, _, rest = name.partition(".")
    if head in SCENARIO_KEYS and head != "events":
        _set_path(scenario, name.split("."), value, where)
    elif head in VERBS and rest:
        event = _single_event(scenario, head, f"{where}: {name}")
        if name in DERIVED_PUSH_FIELDS:
            event["push"]["force"] = _push_force(event["push"].get("force"), name, value, where)
        elif rest == "t":
            event["t"] = value
        else:
            _set_path(event[head], rest.split("."), value, where)
    else:
        raise SweepError(
            f"{where}: unknown field {name!r}: a path into the scenario "
            f"({', '.join(sorted(SCENARIO_KEYS - {'events'}))}) or <verb>.<field> of one of its "
            f"events (verbs: {', '.join(VERBS)})"
        )


def _set_path(table: dict, keys: list[str], value: object, where: str) -> None:
    for key in keys[:-1]:
        table = table.setdefault(key, {})
        if not isinstance(table, dict):
            raise SweepError(f"{where}: {key!r} is not a table")
    table[keys[-1]] = value


def _single_event(scenario: dict, verb: str, where: str) -> dict:
    events = [e for e in scenario.get("events", []) if verb in e]
    if len(events) != 1:
        raise SweepError(f"{where}: the base scenario has {len(events)} {verb} events, needs 1")
    return events[0]


def _push_force(force: object, name: str, value: object, where: str) -> list[float]:
    """A push force with its magnitude (push.force_n) or horizontal direction changed."""
    if not isinstance(value, int | float):
        raise SweepError(f"{where}: {name} must be a number, got {value!r}")
    vector = np.array(force if force is not None else [1.0, 0.0, 0.0], dtype=float)
    magnitude = float(np.linalg.norm(vector))
    if name == "push.force_n":
        unit = vector / magnitude if magnitude > 0 else np.array([1.0, 0.0, 0.0])
        vector = float(value) * unit
    else:
        angle = np.radians(float(value))
        vector = magnitude * np.array([np.cos(angle), np.sin(angle), 0.0])
    return [round(float(x), 9) for x in vector]
