"""What ran is what is reported (issue 27 item 1): the kernel, method, solver and formulation
that computed each tick are in telemetry and `lab run --json`, a request served another way
carries a note, and one status (ok, fallback, capped, violated, failed) with its level and reason
is in telemetry and raises an event."""

import dataclasses
import json

from lab.controller import hierarchy
from lab.controller.native import NOT_BUILT
from lab.experiments.scenario import load_scenario, run_scenario
from lab.world.session import Session, SessionConfig
from tests.helpers.wbosc import BOLT_STACK


def run(session: Session, ticks: int) -> None:
    for _ in range(ticks):
        session.tick()


def test_a_clarabel_request_runs_on_the_python_kernel_and_says_so() -> None:
    """The native kernel compiles DAQP only: asked for Clarabel, the Python kernel runs it and
    the note says why; back on DAQP the native kernel runs again (when built)."""
    session = Session(SessionConfig(method="weighted", solver="clarabel", kernel="native"))
    run(session, 3)
    ran = session.telemetry()["ran"]
    assert {k: ran[k] for k in ("kernel", "method", "solver", "formulation")} == {
        "kernel": "python",
        "method": "weighted",
        "solver": "clarabel",
        "formulation": "qdd_force",
    }
    assert ("clarabel" in ran["note"]) if not NOT_BUILT else (NOT_BUILT in ran["note"])
    assert session.handle("hierarchy", {"method": "weighted", "solver": "daqp"})["ok"]
    run(session, 3)
    ran = session.telemetry()["ran"]
    assert ran["solver"] == "daqp" and ran["kernel"] == ("python" if NOT_BUILT else "native")
    assert ran["note"] == NOT_BUILT


def test_methods_without_a_qp_or_formulation_report_what_they_use() -> None:
    """nullspace and wbosc solve no QP (solver `none`); only nullspace has formulations: a
    formulation kept across a switch to cascade is named in the note, not reported as run."""
    session = Session(SessionConfig(method="nullspace", formulation="full", kernel="python"))
    run(session, 2)
    ran = session.telemetry()["ran"]
    assert (ran["method"], ran["solver"], ran["formulation"]) == ("nullspace", "none", "full")
    assert "nullspace solves no QP (solver 'daqp' unused)" in ran["note"]
    assert session.handle("hierarchy", {"method": "cascade"})["ok"]
    run(session, 2)
    ran = session.telemetry()["ran"]
    assert (ran["method"], ran["solver"], ran["formulation"]) == ("cascade", "daqp", "qdd_force")
    assert "formulation 'full' is nullspace's" in ran["note"]


def test_a_scenario_report_names_what_computed_its_ticks(tmp_path) -> None:
    """`lab run --json` names what ran the last tick and every combination with its ticks."""
    path = tmp_path / "switch.toml"
    path.write_text(
        'robot = "anymal"\nduration = 0.02\n[controller]\nmethod = "weighted"\n'
        'solver = "clarabel"\nkernel = "native"\n'
        '[[events]]\nt = 0.01\nhierarchy = { method = "cascade", solver = "daqp" }\n'
    )
    report = run_scenario(load_scenario(path))
    json.dumps(report)  # JSON-ready
    native = "python" if NOT_BUILT else "native"
    assert (report["kernel"], report["method"], report["solver"]) == (native, "cascade", "daqp")
    assert report["formulation"] == "qdd_force"
    ran = {(r["kernel"], r["method"], r["solver"]): r["ticks"] for r in report["ran"]}
    assert ran == {("python", "weighted", "clarabel"): 10, (native, "cascade", "daqp"): 10}


def test_a_violation_is_the_status_with_its_level_and_an_event() -> None:
    """wbosc does not enforce inequalities: a 100 N internal force on Bolt (6 N of weight per
    foot, μ = 0.8) breaks friction at level 0. The status says so once, with the level and the
    violations; a solver_violation event carries it; the tick is not a failure."""
    session = Session(SessionConfig(robot="bolt", method="wbosc", stack=BOLT_STACK))
    run(session, 5)
    assert session.telemetry()["status"] == {"status": "ok", "level": None, "reason": ""}
    session.pop_events()
    assert session.handle("internal_force", {"reference": 100.0})["ok"]
    run(session, 1)
    status = session.telemetry()["status"]
    assert status["status"] == "violated" and status["level"] == 0, status
    assert "level 0 friction: exceeded by" in status["reason"]
    events = [e for e in session.pop_events() if e["type"] == "solver_violation"]
    assert len(events) == 1 and (events[0]["status"], events[0]["level"]) == ("violated", 0)
    assert session.qp_failures == 0


def test_a_failed_tick_is_the_status_with_its_reason(monkeypatch) -> None:
    """A tick without a solution: status `failed` with the error; qp counts it."""
    session = Session(SessionConfig(kernel="python"))
    run(session, 2)

    def fail(*_: object) -> None:
        raise FloatingPointError("injected")

    monkeypatch.setattr(session.controller, "solve", fail)
    monkeypatch.setattr(session.controller, "compute", fail)
    run(session, 1)
    telemetry = session.telemetry()
    assert telemetry["status"]["status"] == "failed" and telemetry["status"]["level"] is None
    assert "FloatingPointError: injected" in telemetry["status"]["reason"]
    assert telemetry["qp"]["failures"] == 1


def test_a_session_counts_ticks_by_what_ran() -> None:
    """`ran_ticks`, what the scenario report's `ran` lists: one count per combination."""
    session = Session(SessionConfig(kernel="python"))
    run(session, 4)
    assert session.handle("hierarchy", {"method": "weighted"})["ok"]
    run(session, 3)
    counts = {(r.kernel, r.method): n for r, n in session.ran_ticks.items()}
    assert counts == {("python", "cascade"): 4, ("python", "weighted"): 3}


def test_a_capped_active_set_is_the_status_and_an_event(monkeypatch) -> None:
    """nullspace stopping at its active-set cap: status `capped` (no single level), one
    solver_capped event per 0.5 s, and the torques are still applied (not a failed tick)."""
    session = Session(SessionConfig(method="nullspace", kernel="python"))
    solve = hierarchy.METHODS["nullspace"]
    monkeypatch.setitem(
        hierarchy.METHODS,
        "nullspace",
        lambda problem, solver: dataclasses.replace(solve(problem, solver), capped=True),
    )
    run(session, 3)
    status = session.telemetry()["status"]
    assert (status["status"], status["level"]) == ("capped", None)
    assert "cap" in status["reason"]
    events = [e for e in session.pop_events() if e["type"] == "solver_capped"]
    assert len(events) == 1 and events[0]["count"] == 1
    assert session.qp_failures == 0
