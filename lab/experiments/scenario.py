"""Headless scenarios: a TOML file → a session run as fast as the CPU allows → one JSON report.

A scenario names `robot`, `scene` (with `terrain_seed`, an integer, for a scene with random
terrain: `rough`), `duration` (s), a `[controller]` table (`method`, `solver`,
optional `kernel` — `native` or `python` —, optional `stack` — a list of levels or the name of a
preset in `stacks/` — and `[controller.gains.<task>]` tables), `metrics` to report besides the
standing ones, `realism` (a preset's name, or a `[realism]` table of a `preset` and knobs:
lab/realism/knobs.py), an `[expect]` table (the outcome the run must show:
lab/experiments/expect.py) and
`[[events]]`, each with a time `t` and exactly one command written with the
protocol's verb and fields, for example

    [[events]]
    t = 2.0
    push = { body = "base", force = [0.0, 200.0, 0.0], duration = 0.2 }

Everything is checked before anything runs, and a ScenarioError names the file and the field:
a finite duration of at most DURATION_MAX_S, event times in [0, duration), events and gains as
the protocol checks the commands that carry them (a `[controller.gains.<task>]` of a task that
exists, `kp`/`kd` >= 0, `weight` > 0).
"""

import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.controller.native import KERNELS
from lab.experiments.expect import (
    Expectation,
    ExpectError,
    check_expect,
    parse_expect,
    skipped_expect,
)
from lab.experiments.limits import LimitsError, apply_limits, check_limits
from lab.experiments.metrics import METRICS
from lab.protocol import CommandError, parse_command
from lab.realism.knobs import RealismKnobs, knobs_from, preset
from lab.recording.record import Recorder
from lab.scenes import SEEDED_SCENES
from lab.stack_presets import check_gains, load_stack_preset
from lab.world.memory import long_lived_objects_frozen
from lab.world.session import Session, SessionConfig

SCENARIO_KEYS = {
    "name",
    "description",
    "robot",
    "scene",
    "duration",
    "controller",
    "events",
    "metrics",
    "limits",
    "terrain_seed",
    "expect",
    "realism",
}
CONTROLLER_KEYS = {"method", "solver", "stack", "gains", "kernel"}
# s: the longest run a scenario may ask for (the longest shipped one is 65 s; an hour at 1 kHz
# is 3.6 M ticks, minutes of CPU); a duration of 1e12 s used to ask for 7 PiB of tick times.
DURATION_MAX_S = 3600.0
RENAMED_KEYS = {"hierarchy": "method"}  # old spelling -> the one word for the concept now


class ScenarioError(ValueError):
    """A scenario file that is not well formed; the message says where."""


@dataclass(frozen=True)
class Event:
    t: float
    verb: str
    payload: dict


@dataclass
class Scenario:
    name: str
    duration: float
    config: SessionConfig
    events: list[Event] = field(default_factory=list)
    metrics: tuple[str, ...] = ("standing",)
    limits: dict[str, dict[str, object]] = field(default_factory=dict)
    expect: Expectation | None = None  # the outcome the whole run must show (expect.py)


def load_scenario(path: str | Path) -> Scenario:
    """Read and check a scenario file; every event is validated as the protocol would."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except UnicodeDecodeError as error:
        raise ScenarioError(
            f"{path}: not a text file (byte {error.start} is not UTF-8): a scenario is TOML"
        ) from error
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise ScenarioError(f"{path}: {error}") from error
    return parse_scenario(data, path)


def parse_scenario(data: dict, path: Path) -> Scenario:
    """Check the parsed TOML of a scenario (`path` names it in errors and gives its default
    name); `lab sweep` builds its points' scenarios this way."""
    unknown = set(data) - SCENARIO_KEYS
    if unknown:
        raise ScenarioError(f"{path}: unknown keys {sorted(unknown)}")
    controller = data.get("controller", {})
    if not isinstance(controller, dict):
        raise ScenarioError(f"{path}: [controller] must be a table")
    for old, new in RENAMED_KEYS.items():
        if old in controller:
            raise ScenarioError(f"{path}: [controller] key {old!r} is now called {new!r}")
    unknown = set(controller) - CONTROLLER_KEYS
    if unknown:
        raise ScenarioError(f"{path}: unknown [controller] keys {sorted(unknown)}")
    duration = check_duration(data.get("duration"), f"{path}: duration")
    stack, method, gains = _stack(path, controller)
    terrain_seed = _terrain_seed(path, data)
    kernel = controller.get("kernel")
    if kernel not in (None, *KERNELS):
        raise ScenarioError(f"{path}: [controller] kernel must be one of {KERNELS}, got {kernel!r}")
    config = SessionConfig(
        robot=data.get("robot", "anymal"),
        scene=data.get("scene", "flat"),
        method=method,
        solver=controller.get("solver", "daqp"),
        kernel=kernel,
        stack=stack,
        gains=gains,
        terrain_seed=terrain_seed,
        realism=_realism(path, data),
    )
    metrics = data.get("metrics", [])
    unknown = [name for name in metrics if name not in METRICS]
    if unknown:
        raise ScenarioError(f"{path}: unknown metrics {unknown} (known: {', '.join(METRICS)})")
    raw_events = data.get("events", [])
    if not isinstance(raw_events, list):
        raise ScenarioError(f"{path}: events must be [[events]] tables")
    events = [_event(path, i, raw, duration) for i, raw in enumerate(raw_events)]
    metrics = ("standing", *(name for name in metrics if name != "standing"))
    return Scenario(
        data.get("name", path.stem),
        duration,
        config,
        sorted(events, key=lambda e: e.t),
        metrics,
        limits=_limits(path, data),
        expect=_expect(path, data, metrics),
    )


def _expect(path: Path, data: dict, metrics: tuple[str, ...]) -> Expectation | None:
    if "expect" not in data:
        return None
    try:
        return parse_expect(data["expect"], metrics, path)
    except ExpectError as error:
        raise ScenarioError(str(error)) from error


def _terrain_seed(path: Path, data: dict) -> int | None:
    """`terrain_seed`: a non-negative integer, for a scene with random terrain only."""
    seed = data.get("terrain_seed")
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ScenarioError(f"{path}: terrain_seed must be a non-negative integer, got {seed!r}")
    scene = data.get("scene", "flat")
    if scene not in SEEDED_SCENES:
        raise ScenarioError(
            f"{path}: terrain_seed: scene {scene!r} has no random terrain to seed "
            f"(scenes that do: {', '.join(SEEDED_SCENES)})"
        )
    return seed


def _stack(path: Path, controller: dict) -> tuple[list | None, str, dict]:
    """Levels, method and gains of `[controller]`, where `stack` may name a preset."""
    stack = controller.get("stack")
    method = controller.get("method", "cascade")
    try:
        gains = check_gains(controller.get("gains", {}), f"{path}: [controller.gains")
    except ValueError as error:
        raise ScenarioError(str(error)) from None
    if not isinstance(stack, str):
        return stack, method, gains
    try:
        preset = load_stack_preset(stack)
    except (KeyError, ValueError) as error:
        raise ScenarioError(f"{path}: {error.args[0]}") from error
    merged = {task: {**values, **gains.get(task, {})} for task, values in preset.gains.items()}
    return preset.levels, controller.get("method", preset.method), {**gains, **merged}


def _limits(path: Path, data: dict) -> dict[str, dict[str, object]]:
    try:
        return check_limits(data.get("limits", {}))
    except LimitsError as error:
        raise ScenarioError(f"{path}: {error}") from error


def check_duration(duration: object, where: str) -> float:
    """A run's length (s): a finite positive number of at most DURATION_MAX_S; raises
    ScenarioError naming `where`."""
    if isinstance(duration, bool) or not isinstance(duration, int | float):
        raise ScenarioError(f"{where} must be a number of seconds, got {duration!r}")
    if not 0 < duration <= DURATION_MAX_S:  # NaN fails both
        raise ScenarioError(
            f"{where} must be > 0 and at most DURATION_MAX_S = {DURATION_MAX_S:g} s, "
            f"got {duration!r}"
        )
    return float(duration)


def _realism(path: Path, data: dict) -> RealismKnobs:
    """`realism = "typical"` (a preset's name) or a `[realism]` table (`preset` and knobs over
    it: lab/realism/knobs.py); ideal when absent."""
    raw = data.get("realism", {})
    table = {"preset": raw} if isinstance(raw, str) else raw
    if not isinstance(table, dict):
        raise ScenarioError(f"{path}: realism must be a preset's name or a [realism] table")
    knobs = {key: value for key, value in table.items() if key != "preset"}
    try:
        name = table.get("preset")
        base = RealismKnobs() if name is None else preset(name, data.get("robot", "anymal"))
        return knobs_from(base, knobs)
    except ValueError as error:
        raise ScenarioError(f"{path}: [realism] {error}") from error


def _event(path: Path, index: int, raw: object, duration: float) -> Event:
    where = f"{path}: event {index}"
    if not isinstance(raw, dict):
        raise ScenarioError(f"{where}: must be a table with t and one command")
    t = raw.get("t")
    if isinstance(t, bool) or not isinstance(t, int | float) or not 0 <= t < duration:
        raise ScenarioError(
            f"{where}: t must be a time >= 0 s before the end (duration {duration:g} s), got {t!r}"
        )
    verbs = [key for key in raw if key != "t"]
    if len(verbs) != 1:
        raise ScenarioError(f"{where}: needs exactly one command besides t, got {verbs}")
    verb = verbs[0]
    try:
        parse_command(verb, raw[verb])
    except CommandError as error:
        raise ScenarioError(f"{where}: {error}") from error
    return Event(float(t), verb, raw[verb])


def ran_report(session: Session) -> dict:
    """What computed the run's ticks: `kernel`, `method`, `solver` and `formulation` of the last
    tick, `note` (why they differ from the request, '' when they do not) and `ran`, every
    combination that computed ticks with their count (a scenario may switch method or kernel)."""
    controller = session.controller
    return {
        **controller.ran.report(),
        "note": controller.note,
        "ran": [{**ran.report(), "ticks": n} for ran, n in session.ran_ticks.items()],
    }


def run_scenario(
    scenario: Scenario, duration: float | None = None, record: str | Path | None = None
) -> dict:
    """Run headless and report; `duration` shortens the run (tests run short versions), `record`
    names an MCAP file to record the run to (see recording.py). The report's `expect` section
    checks the scenario's `[expect]` table when the run was not cut short."""
    session = Session(scenario.config)
    apply_limits(session.controller, scenario.limits)
    recorder = None if record is None else Recorder(record, session, scenario.limits)
    cut = duration is not None and duration < scenario.duration
    duration = scenario.duration if duration is None else min(duration, scenario.duration)
    ticks = max(1, round(duration / scenario.config.timestep))
    pending = list(scenario.events)
    tick_us = np.zeros(ticks)
    metrics = [METRICS[name](session) for name in scenario.metrics]
    rejected = []
    wall_start = time.perf_counter()
    with long_lived_objects_frozen():  # as the server's loop ticks (world/memory.py)
        for i in range(ticks):
            while pending and pending[0].t <= session.time + 1e-9:
                event = pending.pop(0)
                reply = session.handle(event.verb, event.payload)
                if recorder is not None:
                    recorder.command(session, event.verb, event.payload, reply)
                if not reply["ok"]:
                    rejected.append(f"t={event.t}: {event.verb}: {reply['error']}")
            start = time.perf_counter()
            session.tick()
            tick_us[i] = (time.perf_counter() - start) * 1e6
            for metric in metrics:
                metric.update(session)
            if recorder is not None:
                recorder.after_tick(session)
            if session.fell or session.divergences:  # a diverged run ends as a fallen one does
                break
    wall = time.perf_counter() - wall_start
    if recorder is not None:
        recorder.close()
    report = {
        "scenario": scenario.name,
        "robot": scenario.config.robot,
        **ran_report(session),
        "fell": session.fell,
        "divergences": session.divergences,
        "sim_time_s": session.time,
        "wall_time_s": wall,
        "realtime_factor": session.time / wall if wall > 0 else float("inf"),
        "tick_us": {
            "p50": float(np.percentile(tick_us[: i + 1], 50)),
            "p99": float(np.percentile(tick_us[: i + 1], 99)),
            "max": float(np.max(tick_us[: i + 1])),
        },
        "qp_failures": session.qp_failures,
        "realism": {**session.realism.knobs.values(), "kernel": session.realism.kernel},
        "rejected_events": rejected,
        "metrics": {key: value for m in metrics for key, value in m.result().items()},
    }
    if scenario.expect is None:
        report["expect"] = skipped_expect("the scenario states no [expect]")
    elif cut:
        report["expect"] = skipped_expect(
            f"run cut to {duration:g} s of {scenario.duration:g}: a whole-run expectation "
            "is not checked"
        )
    else:
        report["expect"] = check_expect(scenario.expect, report)
    return report
