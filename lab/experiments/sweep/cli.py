"""`lab sweep`: run a sweep file's points on Ray into one results table, optionally plot it."""

import argparse
import json
import sys
from pathlib import Path

from lab.experiments.sweep.spec import SweepError, load_sweep
from lab.experiments.sweep.table import ERROR, read_rows

OUTPUT_DIR = Path("out/sweeps")


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0.0 or value == float("inf"):  # NaN fails the first test
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, not {text}")
    return value


def sweep_main(argv: list[str]) -> int:
    """`lab sweep SWEEP.toml [--workers N | --address HOST:PORT] [--output F.csv] [--plot]`."""
    parser = argparse.ArgumentParser(
        prog="lab sweep",
        description="Run a sweep of headless scenarios as Ray tasks into one CSV table "
        "(a rerun skips the points already in it).",
    )
    parser.add_argument("sweep", help="path to a sweep TOML file (see sweeps/)")
    parser.add_argument(
        "--workers", type=_positive_int, help="tasks at a time (default: the machine's cores)"
    )
    parser.add_argument(
        "--address", help="an existing Ray cluster (HOST:PORT of `ray start --head`)"
    )
    parser.add_argument(
        "--connect-timeout",
        type=_positive_float,
        help="s to reach the cluster at --address and for its answer (default: runner.py's "
        "CONNECT_TIMEOUT_S, 5 s)",
    )
    parser.add_argument("--output", help=f"results table (default {OUTPUT_DIR}/<name>.csv)")
    parser.add_argument("--timeout", type=float, help="s a point may take (default: the file's)")
    parser.add_argument(
        "--retry-failed", action="store_true", help="rerun the points whose row is an error"
    )
    parser.add_argument(
        "--plot",
        nargs="?",
        const=True,
        metavar="FILE.png",
        help="draw the push-recovery map, or a bisecting sweep's robustness map (default: "
        "beside the table)",
    )
    args = parser.parse_args(argv)
    try:
        sweep = load_sweep(args.sweep)
    except SweepError as error:
        print(f"lab sweep: {error}", file=sys.stderr)
        return 2
    if args.timeout is not None:
        sweep.timeout = args.timeout
    output = Path(args.output or OUTPUT_DIR / f"{sweep.name}.csv")
    try:
        from lab.experiments.sweep.runner import RayUnavailable, run_sweep
    except ImportError as error:
        print(f"lab sweep: {error}: install with pip install -e '.[sweep]'", file=sys.stderr)
        return 2
    try:
        bound = {} if args.connect_timeout is None else {"connect_timeout": args.connect_timeout}
        outcome = run_sweep(sweep, output, args.workers, args.address, args.retry_failed, **bound)
    except RayUnavailable as error:
        print(f"lab sweep: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C before the points ran (while Ray started, or joined)
        print("lab sweep: interrupted before any point ran", file=sys.stderr)
        return 130
    run = outcome.ok + outcome.failed
    rate = f", {60 * run / outcome.wall_s:.1f} points/min" if run else ""
    print(
        f"{sweep.name}: {outcome.ok} ok, {outcome.failed} failed, {outcome.skipped} already in "
        f"{output}; {outcome.wall_s:.0f} s (Ray start {outcome.ray_start_s:.0f} s){rate}"
        + (" (interrupted)" if outcome.interrupted else "")
    )
    rows = read_rows(output)
    for series in sweep.series:  # a bisecting sweep: what each series found
        state, ran = series.state(rows)
        failed = "none" if state.smallest_failed is None else f"{state.smallest_failed:g}"
        print(
            f"  {json.dumps(series.fields, sort_keys=True)} {series.axis.field}: succeeded up to "
            f"{state.largest_ok:g}, failed at {failed} ({len(ran)} runs"
            + ("" if state.next is None else ", unfinished")
            + ")"
        )
    if args.plot:
        from lab.experiments.sweep.plot import PlotError, plot_push_map, plot_robustness

        png = output.with_suffix(".png") if args.plot is True else Path(args.plot)
        try:
            if sweep.series:
                print(f"robustness map: {plot_robustness(sweep, rows, png)}")
            else:
                print(f"push-recovery map: {plot_push_map(rows, png, sweep.name)}")
        except PlotError as error:
            print(f"lab sweep --plot: {error}", file=sys.stderr)
            return 2
    if outcome.interrupted:
        return 130
    return 1 if any(row[ERROR] for row in rows) else 0
