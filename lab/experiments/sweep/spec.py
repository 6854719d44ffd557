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
    base = "../scenarios/solo12_push_lateral.toml"  # a point may name its own base scenario

    [bisect]                 # optional: per point, the largest value of each field that succeeds
    "realism.command_delay" = { range = [0, 32], steps = 4 }

With `[bisect]`, each point of the grid, samples and points is a series per bisected field (the
others at the base's value): the run at the range's top, then up to `steps` runs halving the
interval between the largest value that succeeded (the range's bottom, the base scenario, taken
as succeeding) and the smallest that did not; a run succeeds when it finished without falling.
Integer ranges bisect on integers. The runs of one round go out together (bisect_next).

A field is a dotted path into the scenario's TOML (`robot`, `scene`, `duration`, `metrics`,
`controller.method`, `controller.kernel`, `controller.stack`, `controller.gains.<task>.kp`, ...)
or `<verb>.<field>` of the base scenario's one event with that protocol verb (`push.duration`,
`push.body`, `velocity.vx`, `gait.name`; `<verb>.t` is the event's time). Two fields are
derived from a push's force vector: `push.force_n` (its magnitude, direction kept) and
`push.direction_deg` (its horizontal direction, degrees about z from +x, magnitude kept).

Just over 400 lines: the sweep file's whole grammar (grid, samples, points, bisection and the
derived push fields), each part checked where it is read, as one reader of the format expects.
"""

import copy
import itertools
import json
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.experiments.scenario import SCENARIO_KEYS, Scenario, ScenarioError, parse_scenario
from lab.protocol import VERBS

SWEEP_KEYS = {"name", "description", "base", "duration", "timeout", "set", "grid", "sample"}
SWEEP_KEYS |= {"points", "bisect"}
DEFAULT_TIMEOUT = 600.0  # s of wall time per point
DERIVED_PUSH_FIELDS = ("push.force_n", "push.direction_deg")


class SweepError(ValueError):
    """A sweep file that is not well formed, or a field that does not fit its base scenario."""


@dataclass(frozen=True)
class Point:
    """One scenario of a sweep: the varied fields' values, the scenario TOML they give, and
    the base scenario's path (relative paths in the scenario are read from there)."""

    fields: dict[str, object]
    scenario: dict
    base: Path | None = None

    @property
    def key(self) -> str:
        """The point's identity in a results table (its field values as sorted JSON)."""
        return point_key(self.fields)


@dataclass(frozen=True)
class Axis:
    """A bisected field: its range [lo, hi], the number of halvings after the run at hi, and
    whether its values are integers (both ends written as integers)."""

    field: str
    lo: float
    hi: float
    steps: int
    integer: bool

    def value(self, x: float) -> float | int:
        """`x` as this axis's value (an integer on an integer axis)."""
        return int(x) if self.integer else round(float(x), 9)

    def middle(self, ok: float, bad: float) -> float | int | None:
        """The value halfway between a success and a failure; None when none is left between
        them (integers one apart)."""
        if self.integer:
            return None if bad - ok <= 1 else int((ok + bad) // 2)
        return self.value((ok + bad) / 2)


@dataclass
class Series:
    """A bisection: a point's fields (the grid's, a sample's or an explicit point's) and the
    axis varied from them."""

    fields: dict[str, object]
    axis: Axis

    def fields_at(self, value: float | int) -> dict[str, object]:
        """The fields of the series' run at `value`."""
        return {**self.fields, self.axis.field: value}

    def state(self, rows: list[dict[str, object]]) -> tuple["Bisection", list[dict]]:
        """Where the bisection stands given a results table's rows, and its rows in run order."""
        by_key = {str(row["point"]): row for row in rows}
        outcomes: dict[float, bool] = {}
        ran: list[dict] = []
        while True:
            state = bisect(self.axis, outcomes)
            row = None if state.next is None else by_key.get(point_key(self.fields_at(state.next)))
            if row is None:
                return state, ran
            assert state.next is not None
            outcomes[state.next] = succeeded(row)
            ran.append(row)


@dataclass
class Sweep:
    """A parsed sweep file: its points in order and the wall time allowed to each; a bisecting
    sweep has its series instead, and makes its points as the bisection asks for them."""

    name: str
    base: Path
    points: list[Point] = field(default_factory=list)
    fields: list[str] = field(default_factory=list)  # every varied field, in file order
    timeout: float = DEFAULT_TIMEOUT
    series: list[Series] = field(default_factory=list)
    make: Callable[[dict[str, object]], Point] | None = None  # a bisecting sweep's point maker

    def next_points(self, rows: list[dict[str, object]]) -> list[Point]:
        """A bisecting sweep's next round: each unfinished series' next run not in `rows`."""
        return [
            self.point(series.fields_at(state.next))
            for series in self.series
            if (state := series.state(rows)[0]).next is not None
        ]

    def point(self, fields: dict[str, object]) -> Point:
        """The point of `fields` (a bisecting sweep's), added to `points` on first use."""
        key = point_key(fields)
        known = next((p for p in self.points if p.key == key), None)
        if known is not None:
            return known
        assert self.make is not None, "only a bisecting sweep makes points on demand"
        made = self.make(fields)
        self.points.append(made)
        return made


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
    base, base_data = _own_base(path, data["base"], data, str(path))
    combos = _expand(path, data, bisecting="bisect" in data)
    sweep = Sweep(data.get("name", path.stem), base, timeout=_timeout(path, data))
    bases: dict[str, tuple[Path, dict]] = {}

    def make(combo: dict[str, object]) -> Point:
        """The point of `combo`: its base (the sweep's, or the point's own `base`), its fields
        applied, checked as `lab run` would."""
        point_base, scenario = base, base_data
        if "base" in combo:
            own = str(combo["base"])
            if own not in bases:
                bases[own] = _own_base(path, combo["base"], data, f"{path}: [[points]]")
            point_base, scenario = bases[own]
        scenario = copy.deepcopy(scenario)
        for key, value in combo.items():
            if key != "base":
                _apply(scenario, key, value, f"{path}: point {point_key(combo)}")
        scenario["name"] = sweep.name  # not the base's name: a point may change what it says
        check_scenario(scenario, point_base)
        return Point(combo, scenario, point_base)

    if "bisect" in data:
        axes = _axes(path, data["bisect"])
        sweep.series = [Series(combo, axis) for combo in combos for axis in axes]
        named = [*(name for combo in combos for name in combo), *(a.field for a in axes)]
        sweep.fields = list(dict.fromkeys(named))
        sweep.make = make
        for series in sweep.series:  # a misspelt field stops the sweep before Ray starts
            make(series.fields_at(series.axis.value(series.axis.hi)))
        return sweep
    sweep.fields = list(dict.fromkeys(name for combo in combos for name in combo))
    sweep.points = [make(combo) for combo in combos]
    keys = [p.key for p in sweep.points]
    if len(set(keys)) != len(keys):
        raise SweepError(f"{path}: some points are the same point twice")
    return sweep


def _own_base(path: Path, relative: object, sweep: dict, where: str) -> tuple[Path, dict]:
    """A base scenario (the sweep's `base`, or a point's own in [[points]]) prepared for its
    points: the sweep's `duration` and [set] applied. A point changes the scenario (its duration
    too): the base's [expect] is not the point's, and is dropped."""
    if not isinstance(relative, str):
        raise SweepError(f"{where}: base must be a path, got {relative!r}")
    base = (path.parent / relative).resolve()
    try:
        data = tomllib.loads(base.read_text())
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise SweepError(f"{where}: base scenario: {error}") from error
    data.pop("expect", None)
    if "duration" in sweep:
        data["duration"] = sweep["duration"]
    for name, value in sweep.get("set", {}).items():
        _apply(data, name, value, f"{path}: [set]")
    return base, data


def _axes(path: Path, table: object) -> list[Axis]:
    """The [bisect] table: `"field" = { range = [lo, hi], steps = n }` per field."""
    if not isinstance(table, dict) or not table:
        raise SweepError(
            f"{path}: [bisect] must name fields: field = {{range = [lo, hi], steps = n}}"
        )
    axes = []
    for name, law in table.items():
        ends = law.get("range") if isinstance(law, dict) else None
        steps = law.get("steps") if isinstance(law, dict) else None
        if (
            not isinstance(ends, list)
            or len(ends) != 2
            or not all(isinstance(x, int | float) and not isinstance(x, bool) for x in ends)
            or not ends[0] < ends[1]
            or set(law) != {"range", "steps"}
            or not isinstance(steps, int)
            or steps < 0
        ):
            raise SweepError(
                f"{path}: [bisect] {name!r} must be {{range = [lo, hi], steps = n}} with lo < hi "
                "and n ≥ 0 halvings"
            )
        integer = all(isinstance(x, int) for x in ends)
        axes.append(Axis(name, float(ends[0]), float(ends[1]), steps, integer))
    return axes


def succeeded(row: dict[str, object]) -> bool:
    """A bisected run's success: it finished (no error) and the robot did not fall."""
    return not row.get("error") and row.get("fell") is False


@dataclass(frozen=True)
class Bisection:
    """Where a series stands: the next value to run (None when done), the largest value that
    succeeded (the range's bottom when none did) and the smallest that failed (None: none)."""

    next: float | int | None
    largest_ok: float | int
    smallest_failed: float | int | None


def bisect(axis: Axis, outcomes: dict[float, bool]) -> Bisection:
    """A series given its outcomes so far (value → succeeded): the range's top is run first,
    then the middles between the largest success and the smallest failure, `steps` at most."""
    ok: float | int = axis.value(axis.lo)
    failed: float | int | None = None
    value: float | int | None = axis.value(axis.hi)
    runs = 0
    while value is not None and runs <= axis.steps:
        if value not in outcomes:
            return Bisection(value, ok, failed)
        runs += 1
        if outcomes[value]:
            ok = value
        else:
            failed = value
        if failed is None:  # the top succeeded: nothing to halve
            break
        value = axis.middle(ok, failed)
    return Bisection(None, ok, failed)


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


def _expand(path: Path, data: dict, bisecting: bool = False) -> list[dict[str, object]]:
    """The points' field values: grid × samples, then the explicit points (a bisecting sweep
    may have none: its one point is then the base scenario)."""
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
    if not combos and bisecting:
        return [{}]
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
