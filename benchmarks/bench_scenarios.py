"""Every Kim 2016 and Herzog 2016 scenario on both kernels (issue 26): fell or not, every
`[expect]` metric per kernel, the kernels' difference against its tolerance, and the native
kernel's real-time factor with its tick p50/p99.

    nice -n 10 .venv/bin/python benchmarks/bench_scenarios.py [--only native] [--jobs 2]
        [--scenarios kim_wedges_100n bolt_walk_planner ...] [--json FILE]

A benchmark, not a test: each scenario runs whole, as `lab run` runs it (`run_scenario`), once
with `[controller] kernel = "native"` and once with `"python"`, every run in a process of its own,
at most `--jobs` at a time (the native runs first, so that a native run shares the machine with
another native run, not with a Python one). The real-time factor is the report's (simulated s /
wall s of the whole session: MuJoCo, realism, behaviour, controller, metrics), the tick is
`session.tick()`'s time; both depend on the machine's load, so say it (`uptime`) with them.

The kernels' difference is the largest relative difference |a − b| / max(|a|, |b|) over the
`[expect]` metrics, against `tolerance(name)`: where the two runs follow one path (the robot
keeps its contacts) the metrics agree to the rounding of a tick; where contacts are made and
broken (a walk, a slip) or sensors quantize, the two paths part by rounding and the tolerance is
looser (each says why).
"""

import argparse
import json
import math
import os
import sys
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = ROOT / "scenarios"
# Kim 2016 (Bolt) and Herzog 2016 (Talos): the scenarios that replicate them (docs/replications.md)
KIM = ("kim_", "bolt_")
HERZOG = ("herzog_", "talos_arms_single_support", "talos_arms_stand_table2_lqr")
KERNELS = ("native", "python")
TARGET_RTF = 3.0  # issue 26: every Kim and Herzog scenario at >= 3x real time, native


@dataclass(frozen=True)
class Tolerance:
    """The largest relative difference between the kernels' `[expect]` metrics a scenario may
    show, and where it comes from."""

    relative: float
    why: str


# The kernels' tick agree to x within 1e-8 (1 + |x|) (docs/controller.md); a run that keeps its
# contacts integrates that into metrics equal to 1e-11 of their values (docs/replications.md,
# Kim and Herzog: "metrics equal to 1e-11"). Allowed: 1e-9, two decades above what was measured,
# far below the two or three digits replications.md quotes.
SAME_PATH = Tolerance(1e-9, "one path: replications.md measured 1e-11; allowed 1e-9")
# A walk makes and breaks contacts every step: a touchdown a tick earlier on one kernel (its
# contact force crossing the threshold at a different rounding) moves every later state, so the
# two walks part after a few steps. No doc states a tolerance for it; the one stated here: both
# kernels within the scenario's [expect] bounds and the metrics within 10 % of each other (the
# [expect] bounds are 30-100 % wide around the values replications.md quotes).
PARTED_PATH = Tolerance(0.10, "walk: paths part by rounding; stated here: 10 %")
# Sensors that quantize and add noise (`realism = "typical"`): a rounding difference that moves a
# joint across an encoder step becomes a whole step (the noise itself is drawn the same on both
# kernels, docs/realism.md). No doc states a tolerance; stated here: 1 %, a tenth of the [expect]
# bands of kim_wedges_100n_typical.
SENSED_PATH = Tolerance(0.01, "quantized sensors: a rounding becomes an encoder step; 1 %")
# A run that slips and falls (Kim Fig. 7): once a foot slides down its wedge the two runs part
# without bound, and the round-11 page that first compared the kernels (`git show
# fe8d29c:docs/performance.md`) compared only the outcome: fell on both, [expect] met on both.
FALL = Tolerance(math.inf, "falls: after the slip the paths part; outcome only (round 11)")


def tolerance(name: str) -> Tolerance:
    """The tolerance of scenario `name` on the kernels' difference."""
    if name == "kim_wedges_10n":
        return FALL
    if name.startswith("bolt_"):
        return PARTED_PATH
    if name.endswith("_typical"):
        return SENSED_PATH
    return SAME_PATH


def scenario_names(only: list[str] | None) -> list[str]:
    """The shipped Kim and Herzog scenarios (or those of `only`, checked to exist)."""
    shipped = sorted(p.stem for p in SCENARIOS.glob("*.toml"))
    if only:
        unknown = [name for name in only if name not in shipped]
        if unknown:
            raise SystemExit(f"bench_scenarios: no scenarios/{unknown[0]}.toml")
        return only
    return [name for name in shipped if name.startswith(KIM + HERZOG)]


def scenario_duration(name: str) -> float:
    """The simulated seconds scenario `name` runs."""
    with (SCENARIOS / f"{name}.toml").open("rb") as file:
        return float(tomllib.load(file)["duration"])


def run_one(name: str, kernel: str) -> dict:
    """One whole run of scenario `name` on `kernel` (in a worker process): the report of
    `lab run --json`, with `cpu_time_s`, the process's CPU time from the session built to the
    report (what `wall_time_s` times, but for the others' share of a shared machine), and
    `cpu_realtime_factor`, simulated s over it."""
    from lab.experiments import scenario as scenario_module

    built_at: list[float] = []
    session_class = scenario_module.Session

    def session_timed(config):  # run_scenario's session, the CPU clock read once it is built
        session = session_class(config)
        built_at.append(time.process_time())
        return session

    scenario = scenario_module.load_scenario(SCENARIOS / f"{name}.toml")
    scenario.config.kernel = kernel
    scenario_module.Session = session_timed
    try:
        report = scenario_module.run_scenario(scenario)
    finally:
        scenario_module.Session = session_class
    report["cpu_time_s"] = time.process_time() - built_at[0]
    report["cpu_realtime_factor"] = report["sim_time_s"] / report["cpu_time_s"]
    return report


def relative_difference(a: float, b: float) -> float:
    """|a − b| / max(|a|, |b|); 0 when both are 0, inf when one is not finite."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return 0.0 if a == b else math.inf
    scale = max(abs(a), abs(b))
    return 0.0 if scale == 0.0 else abs(a - b) / scale


def kernels_ran(report: dict) -> str:
    """Every kernel that computed ticks, with the share of ticks (a run asked of one kernel that
    ran on another says so here)."""
    ticks: dict[str, int] = {}
    for ran in report["ran"]:
        ticks[ran["kernel"]] = ticks.get(ran["kernel"], 0) + ran["ticks"]
    return "+".join(sorted(ticks))


def compare(name: str, reports: dict[str, dict]) -> dict:
    """One scenario's row: per kernel what ran, fell, expect passed and every `[expect]`
    value; between the kernels the largest relative difference and whether it is within the
    tolerance; the native run's real-time factor and tick."""
    tol = tolerance(name)
    row: dict = {"scenario": name, "tolerance": tol.relative, "tolerance_why": tol.why}
    for kernel, report in reports.items():
        row[kernel] = {
            "ran": kernels_ran(report),
            "fell": report["fell"],
            "sim_time_s": report["sim_time_s"],
            "wall_time_s": report["wall_time_s"],
            "realtime_factor": report["realtime_factor"],
            "cpu_realtime_factor": report["cpu_realtime_factor"],
            "tick_us": report["tick_us"],
            "qp_failures": report["qp_failures"],
            "expect_passed": report["expect"]["passed"],
            "expect": {c["name"]: c for c in report["expect"]["checks"]},
        }
    if len(reports) == 2:
        native, python = (row[k]["expect"] for k in KERNELS)
        diffs = {
            metric: relative_difference(
                float(native[metric]["value"]), float(python[metric]["value"])
            )
            for metric in native
            if metric != "fell"
            and native[metric]["value"] is not None
            and python[metric]["value"] is not None
        }
        worst = max(diffs.values(), default=0.0)
        same_fall = row["native"]["fell"] == row["python"]["fell"]
        row["metric_difference"] = diffs
        row["largest_difference"] = worst
        # over every metric the reports share, [expect]ed or not (for a reader: no tolerance)
        metrics = [r["metrics"] for r in (reports["native"], reports["python"])]
        row["largest_difference_any_metric"] = max(
            (
                relative_difference(float(metrics[0][k]), float(metrics[1][k]))
                for k in metrics[0]
                if k in metrics[1]
            ),
            default=0.0,
        )
        row["same_outcome"] = (
            same_fall and row["native"]["expect_passed"] == row["python"]["expect_passed"]
        )
        row["agree"] = row["same_outcome"] and worst <= tol.relative
    return row


def print_rows(rows: list[dict]) -> None:
    """The summary table, then every `[expect]` metric per kernel."""
    print(
        f"{'scenario':32} {'sim s':>6} {'fell n/p':>11} {'expect n/p':>11} {'largest diff':>12} "
        f"{'tol':>6} {'agree':>5} {'RTF n':>6} {'tick p50/p99 n µs':>18} {'RTF p':>6}"
    )
    for row in rows:
        n, p = row.get("native"), row.get("python")

        def both(key: str, n=n, p=p) -> str:
            return " / ".join("-" if r is None else str(r[key]) for r in (n, p))

        diff = row.get("largest_difference")
        tick = "-" if n is None else f"{n['tick_us']['p50']:.0f} / {n['tick_us']['p99']:.0f}"
        rtf_n = "-" if n is None else f"{n['realtime_factor']:.2f}"
        rtf_p = "-" if p is None else f"{p['realtime_factor']:.2f}"
        print(
            f"{row['scenario']:32} {(n or p)['sim_time_s']:6.1f} {both('fell'):>11} "
            f"{both('expect_passed'):>11} {'-' if diff is None else f'{diff:.1e}':>12} "
            f"{row['tolerance']:6.0e} {row.get('agree', '-')!s:>5} "
            f"{rtf_n:>6} {tick:>18} "
            f"{rtf_p:>6}"
        )
    print()
    for row in rows:
        for kernel in KERNELS:
            if kernel in row and row[kernel]["ran"] != kernel:
                print(f"{row['scenario']}: asked {kernel}, ran {row[kernel]['ran']}")
        first = row.get("native") or row["python"]
        for metric, check in first["expect"].items():
            values = []
            for kernel in KERNELS:
                if kernel in row:
                    c = row[kernel]["expect"][metric]
                    values.append(f"{kernel} {c['value']} ({'ok' if c['passed'] else 'FAILS'})")
            bounds = (
                f"expected {check['expected']}"
                if metric == "fell"
                else f"in [{check['min']}, {check['max']}]"
            )
            print(f"  {row['scenario']:32} {metric:34} {bounds:28} {', '.join(values)}")


def print_markdown(rows: list[dict]) -> None:
    """docs/performance.md's table: one row a scenario, a dash where a kernel did not run."""
    print(
        "| scenario | sim s | fell native / python | [expect] met native / python | largest "
        "[expect] difference (tolerance); over every metric | native RTF wall / CPU | "
        "native tick p50 / p99 µs |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    yes = {True: "yes", False: "**no**", None: "-"}
    for row in rows:
        n, p = row.get("native"), row.get("python")
        fell = " / ".join("-" if r is None else ("fell" if r["fell"] else "stood") for r in (n, p))
        met = " / ".join("-" if r is None else yes[r["expect_passed"]] for r in (n, p))
        diff = row.get("largest_difference")
        agree = "" if diff is None or row["agree"] else " **over**"
        allowed = "outcome only" if math.isinf(row["tolerance"]) else f"{row['tolerance']:g}"
        difference = "-" if diff is None else f"{diff:.1e} ({allowed}){agree}"
        if diff is not None:
            difference += f"; every metric {row['largest_difference_any_metric']:.1e}"
        rtf = "-" if n is None else f"{n['realtime_factor']:.2f} / {n['cpu_realtime_factor']:.2f}"
        mark = "" if n is None or n["cpu_realtime_factor"] >= TARGET_RTF else " **<3**"
        tick = "-" if n is None else f"{n['tick_us']['p50']:.0f} / {n['tick_us']['p99']:.0f}"
        sim = (n or p)["sim_time_s"]
        cells = (f"`{row['scenario']}`", f"{sim:.1f}", fell, met, difference, rtf + mark, tick)
        print(f"| {' | '.join(cells)} |")


def run_all(runs: list[tuple[str, str]], jobs: int, reports: Path) -> None:
    """Run each (scenario, kernel) whose report `reports` lacks, at most `jobs` at a time, and
    save each report there as it ends (so that an interrupted run resumes)."""
    todo = [run for run in runs if not report_path(reports, *run).exists()]
    reports.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max_workers=jobs, max_tasks_per_child=1) as pool:
        futures = {pool.submit(run_one, *run): run for run in todo}
        for future in as_completed(futures):
            name, kernel = futures[future]
            report = future.result()
            report_path(reports, name, kernel).write_text(json.dumps(report))
            print(
                f"{name} {kernel}: fell {report['fell']}, expect {report['expect']['passed']}, "
                f"RTF {report['realtime_factor']:.2f}, load {os.getloadavg()[0]:.1f}",
                flush=True,
            )


def report_path(reports: Path, name: str, kernel: str) -> Path:
    """Where the report of `name` run on `kernel` is kept."""
    return reports / f"{name}.{kernel}.json"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", choices=KERNELS, help="run one kernel only")
    parser.add_argument("--jobs", type=int, default=2, help="runs at a time (at most 2 here)")
    parser.add_argument("--scenarios", nargs="+", help="these scenarios (default: Kim, Herzog)")
    parser.add_argument(
        "--reports",
        type=Path,
        default=ROOT / "out" / "bench_scenarios",
        help="where each run's report is kept; a run whose report is there is not run again",
    )
    parser.add_argument("--fresh", action="store_true", help="run again what --reports holds")
    parser.add_argument("--json", type=Path, help="write every row to this file")
    parser.add_argument(
        "--table-only",
        action="store_true",
        help="run nothing: tabulate the reports --reports holds (a kernel's missing runs: -)",
    )
    parser.add_argument("--markdown", action="store_true", help="docs/performance.md's table too")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error("--jobs must be at least 1")
    names = scenario_names(args.scenarios)
    kernels = (args.only,) if args.only else KERNELS
    # the native runs first (they share the machine with each other), each kernel's shortest
    # scenarios first (an interrupted run has the most scenarios on both kernels)
    by_length = sorted(names, key=scenario_duration)
    runs = [(name, kernel) for kernel in kernels for name in by_length]
    if args.fresh:
        for run in runs:
            report_path(args.reports, *run).unlink(missing_ok=True)
    start = time.monotonic()
    print(f"load average at start: {os.getloadavg()}", flush=True)
    if not args.table_only:
        run_all(runs, args.jobs, args.reports)
    rows = []
    for name in names:
        found = {k: report_path(args.reports, name, k) for k in kernels}
        reports = {k: json.loads(f.read_text()) for k, f in found.items() if f.exists()}
        if reports:
            rows.append(compare(name, reports))
    print_rows(rows)
    if args.markdown:
        print()
        print_markdown(rows)
    for clock, key in (("wall", "realtime_factor"), ("CPU", "cpu_realtime_factor")):
        slow = [r["scenario"] for r in rows if "native" in r and r["native"][key] < TARGET_RTF]
        below = ", ".join(slow) or "none"
        print(f"\nbelow {TARGET_RTF:g}x real time, native, by {clock} time: {below}")
    print(f"wall {time.monotonic() - start:.0f} s, {args.jobs} at a time")
    print(f"load average at end: {os.getloadavg()}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
