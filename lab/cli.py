"""`lab`: the command line. `lab run`, `lab replay`, `lab bench`, `lab serve`, `lab soak`,
`lab teleop`, `lab sweep`, `lab report`, `lab router`, `lab robot`."""

import argparse
import json
import sys
from dataclasses import asdict


def _run(argv: list[str]) -> int:
    """`lab run`: exit 0 when the scenario's [expect] holds (without one, or cut short by
    --duration: when the robot did not fall), 1 naming what failed, 2 for bad input."""
    from lab.experiments.expect import failed_checks
    from lab.experiments.scenario import ScenarioError, check_duration, load_scenario, run_scenario

    parser = argparse.ArgumentParser(
        prog="lab run",
        description="Run a headless scenario and check its [expect] table (exit 1 naming "
        "what failed; a run cut by --duration is not checked).",
    )
    parser.add_argument("scenario", help="path to a scenario TOML file")
    parser.add_argument("--json", action="store_true", help="print the report as one JSON object")
    parser.add_argument("--duration", type=float, help="stop earlier than the scenario's duration")
    parser.add_argument("--record", metavar="FILE.mcap", help="record the run to an MCAP file")
    args = parser.parse_args(argv)
    try:
        if args.duration is not None:
            check_duration(args.duration, "--duration")
        scenario = load_scenario(args.scenario)
        report = run_scenario(scenario, args.duration, args.record)
    except (ScenarioError, KeyError, ValueError) as error:
        print(f"lab run: {error.args[0] if error.args else error}", file=sys.stderr)
        return 2
    except OSError as error:  # a --record file it cannot write
        print(f"lab run: {error}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(report))
    else:
        metrics = ", ".join(f"{k} {v:.4g}" for k, v in report["metrics"].items())
        print(
            f"{report['scenario']}: fell={report['fell']} sim {report['sim_time_s']:.2f} s "
            f"in {report['wall_time_s']:.2f} s ({report['realtime_factor']:.1f}x real time), "
            f"tick p50 {report['tick_us']['p50']:.0f} µs p99 {report['tick_us']['p99']:.0f} µs, "
            f"QP failures {report['qp_failures']}; {metrics}"
        )
    expect = report["expect"]
    if not expect["checked"]:
        print(f"lab run: expectations not checked: {expect['note']}", file=sys.stderr)
        return 1 if report["fell"] else 0
    failed = failed_checks(expect)
    for line in failed:
        print(f"lab run: {report['scenario']}: expectation failed: {line}", file=sys.stderr)
    return 1 if failed else 0


def _replay(argv: list[str]) -> int:
    from lab.recording.replay import replay

    parser = argparse.ArgumentParser(
        prog="lab replay",
        description="Replay a recording through a new session and compare its torques, or "
        "serve it (--serve).",
    )
    parser.add_argument("recording", help="an MCAP file written by --record")
    parser.add_argument(
        "--serve",
        action="store_true",
        help="serve the recording over the protocol like a live session (pause, speed, seek)",
    )
    parser.add_argument(
        "--port", type=int, default=7447, help="with --serve: TCP port on 127.0.0.1"
    )
    parser.add_argument("--speed", type=float, default=1.0, help="with --serve: times real time")
    parser.add_argument(
        "--lab-id", help="with --serve: the lab id its keys are scoped by (default: <host>-replay)"
    )
    parser.add_argument(
        "--ui-port", type=int, default=8080, help="with --serve: HTTP port of the browser UI"
    )
    parser.add_argument(
        "--headless", action="store_true", help="with --serve: do not start the browser UI"
    )
    args = parser.parse_args(argv)
    if args.serve:
        from lab.recording.replay_serve import replay_serve_main

        ui_port = None if args.headless else args.ui_port
        return replay_serve_main(args.recording, args.port, args.speed, args.lab_id, ui_port)
    try:
        check = replay(args.recording)
    except (OSError, ValueError, KeyError) as error:
        print(f"lab replay: {error}", file=sys.stderr)
        return 2
    if check.cut_short:
        print(f"lab replay: {args.recording}: {check.cut_short}", file=sys.stderr)
    print(json.dumps(asdict(check)))
    return 0


def _robot(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="lab robot", description="Add a robot from a URDF, or check one (docs/robots.md)."
    )
    verbs = parser.add_subparsers(dest="verb", required=True)
    new = verbs.add_parser("new", help="write robots/NAME.toml from a URDF, for you to edit")
    new.add_argument("name", help="the robot's name (lower case, digits, _)")
    new.add_argument(
        "--urdf", required=True, help="a .urdf file, or an example-robot-data robot (go1)"
    )
    check = verbs.add_parser("check", help="both engines, the feet at rest, a standing run")
    check.add_argument("name", help="a robot in robots/")
    check.add_argument("--seconds", type=float, default=5.0, help="how long it must stand")
    args = parser.parse_args(argv)
    if args.verb == "new":
        from lab.experiments.robot_new import new_robot

        try:
            path = new_robot(args.name, args.urdf)
        except (OSError, ValueError) as error:
            print(f"lab robot new: {error}", file=sys.stderr)
            return 2
        print(f"wrote {path}: edit it, then `lab robot check {args.name}`")
        return 0
    from lab.experiments.robot_check import check_robot

    findings = check_robot(args.name, args.seconds)
    for finding in findings:
        print(f"{'ok  ' if finding.ok else 'FAIL'} {finding.check}: {finding.message}")
    return 0 if all(finding.ok for finding in findings) else 1


def _bench(argv: list[str]) -> int:
    from lab.experiments.bench import bench_main

    return bench_main(argv)


def _serve(argv: list[str]) -> int:
    from lab.runtime.serve import serve_main

    return serve_main(argv)


def _soak(argv: list[str]) -> int:
    from lab.experiments.soak import soak_main

    return soak_main(argv)


def _router(argv: list[str]) -> int:
    from lab.runtime.router import router_main

    return router_main(argv)


def _sweep(argv: list[str]) -> int:
    from lab.experiments.sweep.cli import sweep_main

    return sweep_main(argv)


def _report(argv: list[str]) -> int:
    from lab.experiments.report import report_main

    return report_main(argv)


def _protocol(argv: list[str]) -> int:
    from lab.protocol.schema import schema_main

    return schema_main(argv)


def _teleop(argv: list[str]) -> int:
    from lab.teleop import teleop_main

    return teleop_main(argv)


COMMANDS = {
    "run": _run,
    "replay": _replay,
    "bench": _bench,
    "serve": _serve,
    "soak": _soak,
    "teleop": _teleop,
    "sweep": _sweep,
    "report": _report,
    "router": _router,
    "robot": _robot,
    "protocol": _protocol,
}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] not in COMMANDS:
        print(f"usage: lab {{{','.join(COMMANDS)}}} [args]  (lab <command> -h for help)")
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    return COMMANDS[argv[0]](argv[1:])
