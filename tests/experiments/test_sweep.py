"""`lab sweep`: sweep files expand into the right scenarios; a small sweep on a local Ray
instance with 2 workers gives the table single runs give; failures are rows; reruns resume."""

import math
from pathlib import Path

import pytest

from lab.experiments.scenario import run_scenario
from lab.experiments.sweep.spec import SweepError, check_scenario, load_sweep, point_key
from lab.experiments.sweep.table import ERROR, KEY, read_rows, write_rows

BASE = Path(__file__).resolve().parent.parent.parent / "scenarios" / "anymal_push_lateral.toml"
# Wall-clock columns differ from run to run; every other report entry must match.
TIMING = ("wall_time_s", "realtime_factor", "tick_us.p50", "tick_us.p99", "tick_us.max")

SMALL_SWEEP = f"""
name = "small"
base = "{BASE}"
duration = 0.8

[set]
metrics = ["cog_tracking"]
"push.t" = 0.3
"push.duration" = 0.15

[grid]
"controller.method" = ["cascade", "weighted"]
"push.direction_deg" = [0.0, 90.0]
"push.force_n" = [120.0]

[[points]]
robot = "no_such_robot"
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    return path


def test_fields_reach_the_scenario(tmp_path):
    sweep = load_sweep(_write(tmp_path, SMALL_SWEEP))
    assert len(sweep.points) == 5
    point = sweep.points[1]  # cascade, 90°
    assert point.fields == {
        "controller.method": "cascade",
        "push.direction_deg": 90.0,
        "push.force_n": 120.0,
    }
    scenario = check_scenario(point.scenario, BASE)
    assert scenario.duration == 0.8 and scenario.config.method == "cascade"
    assert "cog_tracking" in scenario.metrics
    (push,) = scenario.events
    assert push.t == 0.3 and push.payload["duration"] == 0.15
    assert push.payload["force"] == pytest.approx([0.0, 120.0, 0.0], abs=1e-9)


def test_sample_is_seeded_and_bad_fields_are_named(tmp_path):
    sampled = f"""base = "{BASE}"
[sample]
n = 4
seed = 3
"push.force_n" = {{ uniform = [50.0, 100.0] }}
"controller.method" = {{ choice = ["cascade", "nullspace"] }}
"""
    first, second = (load_sweep(_write(tmp_path, sampled)).points for _ in range(2))
    assert [p.fields for p in first] == [p.fields for p in second]
    assert all(50.0 <= p.fields["push.force_n"] <= 100.0 for p in first)
    for bad, message in [
        ('[grid]\n"controller.gainz" = [1]', "unknown \\[controller\\] keys"),
        ('[grid]\n"kick.force_n" = [1]', "unknown field 'kick.force_n'"),
        ('[grid]\n"velocity.vx" = [0.1]', "has 0 velocity events"),
        ('[grid]\n"controller.method" = []', "non-empty list"),
        ('[grid]\n"controller.method" = ["cascade", "cascade"]', "same point twice"),
    ]:
        with pytest.raises(SweepError, match=message):
            load_sweep(_write(tmp_path, f'base = "{BASE}"\n{bad}\n'))


def test_table_round_trip(tmp_path):
    rows = [
        {KEY: '{"a": 1}', "a": 1, ERROR: "", "fell": False, "force": [0.0, 1.5], "m": "x"},
        {KEY: '{"a": 2}', "a": 2, ERROR: "KeyError: 'b'", "extra": math.inf},
    ]
    write_rows(tmp_path / "t.csv", rows)
    assert read_rows(tmp_path / "t.csv") == rows


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray instance with 2 workers for the module (Ray takes seconds to start)."""
    import ray

    from lab.experiments.sweep.runner import _start_ray

    _start_ray(2, None)
    yield ray
    ray.shutdown()


def test_sweep_matches_single_runs_and_resumes(local_ray, tmp_path):
    from lab.experiments.sweep.runner import run_sweep

    sweep = load_sweep(_write(tmp_path, SMALL_SWEEP))
    table = tmp_path / "small.csv"
    outcome = run_sweep(sweep, table, workers=2, progress=False)
    assert (outcome.ok, outcome.failed, outcome.skipped) == (4, 1, 0)
    rows = read_rows(table)
    assert [row[KEY] for row in rows] == [point.key for point in sweep.points]

    failed = rows[-1]
    assert failed["robot"] == "no_such_robot" and "no_such_robot" in failed[ERROR]
    for point, row in zip(sweep.points[:-1], rows[:-1], strict=True):
        assert row[ERROR] == "" and row["push.force_n"] == point.fields["push.force_n"]
        single = run_scenario(check_scenario(point.scenario, BASE))
        assert row["fell"] == single["fell"] and row["method"] == single["method"]
        assert row["sim_time_s"] == pytest.approx(single["sim_time_s"], abs=1e-9)
        for name, value in single["metrics"].items():
            assert row[f"metrics.{name}"] == pytest.approx(value, rel=1e-3, abs=1e-6), name
    assert rows[0]["metrics.cog_error_max_m"] > 0.0  # the push moved the CoM

    # A rerun runs nothing; a row lost (as when a sweep is killed) is run again, alone.
    assert run_sweep(sweep, table, workers=2, progress=False).skipped == 5
    write_rows(table, rows[1:])
    outcome = run_sweep(sweep, table, workers=2, progress=False)
    assert (outcome.ok, outcome.failed, outcome.skipped) == (1, 0, 4)
    rerun = read_rows(table)
    assert [row[KEY] for row in rerun] == [row[KEY] for row in rows]
    for old, new in zip(rows, rerun, strict=True):
        assert set(old) == set(new)
        for name in set(old) - set(TIMING):
            expected = old[name]
            if isinstance(expected, float):
                expected = pytest.approx(expected, rel=1e-3, abs=1e-6)
            assert new[name] == expected, name
    outcome = run_sweep(sweep, table, workers=2, retry_failed=True, progress=False)
    assert (outcome.ok, outcome.failed, outcome.skipped) == (0, 1, 4)


def test_push_map_png(tmp_path):
    from lab.experiments.sweep.plot import PlotError, plot_push_map

    rows = [
        {KEY: str(i), ERROR: "", "controller.method": method, "push.force_n": force}
        | {"push.direction_deg": 45.0 * i, "fell": force > 200, "metrics.cog_error_max_m": 0.01}
        for i, (method, force) in enumerate([("cascade", 100), ("cascade", 300), ("weighted", 100)])
    ]
    rows.append(rows[0] | {KEY: "x", ERROR: "timeout", "controller.method": "weighted"})
    png = plot_push_map(rows, tmp_path / "map.png", "test")
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000
    with pytest.raises(PlotError, match=r"push\.direction_deg"):
        plot_push_map([{KEY: "1", ERROR: "", "push.force_n": 1.0}], tmp_path / "no.png", "t")


def test_a_cluster_address_where_nothing_answers_is_refused_at_once():
    """`--address HOST:PORT` with no Ray there: a clear error naming it at once (Ray itself
    would retry for minutes)."""
    from lab.experiments.sweep.runner import RayUnavailable, _start_ray
    from tests.helpers.ports import free_port

    address = f"127.0.0.1:{free_port()}"
    # what `lab sweep --address` does first (run_sweep itself would use a Ray session this
    # module's fixture may have started)
    with pytest.raises(RayUnavailable, match=f"the Ray cluster at {address}: nothing answers"):
        _start_ray(None, address)


@pytest.mark.parametrize(
    ("greeting", "says"),
    [
        (None, "no answer within 2 s"),  # a listener that accepts and says nothing
        (b"SSH-2.0-OpenSSH_9.2\r\n", "it sent b'SSH-2.0-OpenSSH_'"),
        (b"HTTP/1.1 400 Bad Request\r\n\r\n", "it sent b'HTTP/1.1 400 Bad"),
    ],
)
def test_a_cluster_address_where_something_else_listens_is_refused_within_seconds(
    greeting: bytes | None, says: str
) -> None:
    """`ray.init` hung for over 200 s on such a port; the GCS check takes at most its connect
    timeout (`--connect-timeout`; 2 s here, for the silent listener) and names the address."""
    import socket
    import threading

    from lab.experiments.sweep.runner import RayUnavailable, _start_ray

    listener = socket.create_server(("127.0.0.1", 0))
    accepted: list[socket.socket] = []

    def serve() -> None:
        connection, _ = listener.accept()
        accepted.append(connection)
        if greeting is not None:
            connection.sendall(greeting)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    address = f"127.0.0.1:{listener.getsockname()[1]}"
    try:
        with pytest.raises(RayUnavailable) as refused:
            _start_ray(None, address, connect_timeout=2.0)
    finally:
        listener.close()
        for connection in accepted:
            connection.close()
    assert str(refused.value).startswith(f"the Ray cluster at {address}: something listens")
    assert says in str(refused.value) and "ray start --head" in str(refused.value)


def test_ctrl_c_stops_lab_sweep_while_it_waits_for_a_cluster(tmp_path):
    """SIGINT while `lab sweep --address` waits on a port that says nothing: one line, exit 130
    (Ray's own retries used to ignore it)."""
    import signal
    import socket
    import subprocess
    import sys

    listener = socket.create_server(("127.0.0.1", 0))
    address = f"127.0.0.1:{listener.getsockname()[1]}"
    command = [sys.executable, "-m", "lab", "sweep", str(_write(tmp_path, SMALL_SWEEP))]
    output = str(tmp_path / "out.csv")
    sweep = subprocess.Popen(
        # the probe's bound well above any delay of this signal on a busy machine
        [*command, "--address", address, "--connect-timeout", "120", "--output", output],
        stderr=subprocess.PIPE,
        text=True,
        # SIGINT at its default, as from a terminal: a process that starts with it ignored keeps
        # ignoring it (Python installs no handler then), and this test's own process may ignore
        # it (under pytest-xdist on a fresh clone it did: exit 2, "no answer", then a timeout)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        listener.settimeout(120)  # importing Ray first, on a busy machine
        connection, _ = listener.accept()  # the check is waiting for an answer now
        sweep.send_signal(signal.SIGINT)
        assert sweep.wait(60) == 130
        assert sweep.stderr.read() == "lab sweep: interrupted before any point ran\n"
        connection.close()
    finally:
        sweep.kill()
        sweep.wait()
        listener.close()


def test_bisect_finds_the_largest_value_that_succeeds_in_its_steps():
    """On a known threshold: the range's top first, then halvings; integers stop one apart."""
    from lab.experiments.sweep.spec import Axis, bisect

    def run(axis: Axis, threshold: float) -> tuple[list, object]:
        outcomes: dict = {}
        tried = []
        while (state := bisect(axis, outcomes)).next is not None:
            tried.append(state.next)
            outcomes[state.next] = state.next <= threshold
        return tried, state

    tried, state = run(Axis("d", 0, 32, 4, True), 11)
    assert tried == [32, 16, 8, 12, 10] and (state.largest_ok, state.smallest_failed) == (10, 12)
    tried, state = run(Axis("d", 0, 4, 9, True), 2)  # stops one apart, not after 9 halvings
    assert tried == [4, 2, 3] and (state.largest_ok, state.smallest_failed) == (2, 3)
    tried, state = run(Axis("n", 0.0, 0.4, 3, False), 0.13)
    assert tried == [0.4, 0.2, 0.1, 0.15] and state.largest_ok == pytest.approx(0.1)
    tried, state = run(Axis("n", 0.0, 0.4, 3, False), 1.0)  # the top holds: one run
    assert tried == [0.4] and (state.largest_ok, state.smallest_failed) == (0.4, None)


BISECT_SWEEP = f"""
name = "tiny_robustness"
base = "{BASE}"
duration = 4.0

[set]
"push.t" = 0.5

[[points]]
"controller.method" = "cascade"

[bisect]
"realism.command_delay" = {{ range = [0, 48], steps = 1 }}
"realism.mass_error" = {{ range = [0.0, 0.1], steps = 0 }}
"""


def test_a_bisecting_sweep_runs_its_rounds_on_ray_and_resumes(local_ray, tmp_path):
    """A tiny robustness map (scenarios/anymal_push_lateral.toml's 150 N push at 0.5 s, 4 s,
    cascade): a 48-tick command delay fells ANYmal (its balance acts 48 ms late: it sways
    until it falls, at 2.2 s with one build and after 2.5 s with another: the time is chaotic,
    so the run lasts 4 s), half of it is the next run (it tilts 0.003 rad), a 10 % mass error
    (no halving asked) is taken; a rerun runs nothing and the map draws."""
    from lab.experiments.sweep.plot import plot_robustness
    from lab.experiments.sweep.runner import run_sweep

    sweep = load_sweep(_write(tmp_path, BISECT_SWEEP))
    assert [s.axis.field for s in sweep.series] == ["realism.command_delay", "realism.mass_error"]
    table = tmp_path / "tiny.csv"
    outcome = run_sweep(sweep, table, workers=2, progress=False)
    rows = {row[KEY]: row for row in read_rows(table)}
    method = {"controller.method": "cascade"}
    top, middle, mass_run = (
        point_key(method | field)
        for field in (
            {"realism.command_delay": 48},
            {"realism.command_delay": 24},
            {"realism.mass_error": 0.1},
        )
    )
    assert (outcome.ok, outcome.failed) == (3, 0) and set(rows) == {top, middle, mass_run}
    # the report's realism says what ran: the varied knob, the other at the base's value
    assert rows[top]["fell"] is True and rows[top]["realism.mass_error"] == 0.0
    assert rows[mass_run]["fell"] is False and rows[mass_run]["realism.command_delay"] == 0
    delay, mass = (series.state(read_rows(table))[0] for series in sweep.series)
    assert delay.next is None and delay.smallest_failed in (24, 48)
    assert (mass.next, mass.largest_ok, mass.smallest_failed) == (None, 0.1, None)
    assert run_sweep(load_sweep(_write(tmp_path, BISECT_SWEEP)), table, progress=False).ok == 0
    png = plot_robustness(sweep, read_rows(table), tmp_path / "map.png")
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000
