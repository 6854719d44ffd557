"""docs/performance.md's `lab bench` table from `lab bench --json` output: one Markdown row per
native row, its Python tick and native/Python where a file also ran the Python kernel, and the
issue-26 targets (≥ 10× standing, ≥ 5× walking; native/Python ≤ 0.15) met or not.

    .venv/bin/python -m lab bench --seconds 2 --json > paper.json
    .venv/bin/python -m lab bench --seconds 2 --robots talos_arms g1 go2 a1 b1 b1_z1 \\
        --json > more.json
    .venv/bin/python benchmarks/bench_table.py paper.json more.json
"""

import argparse
import json
from pathlib import Path

STANDING_TARGET, WALKING_TARGET = 10.0, 5.0  # real-time factors (issue 26)
RATIO_TARGET = 0.15  # native tick over Python tick, medians (issue 26)


def table_rows(runs: list[dict]) -> list[str]:
    """The Markdown rows of `runs` (each a `lab bench --json` object), in their order."""
    rows = [row for run in runs for row in run["controller_tick"]]
    python = {
        (r["robot"], r["gait"], r["method"]): r["controller_us"]["p50"]
        for r in rows
        if r["kernel"] == "python"
    }
    lines = []
    for r in rows:
        if r["kernel"] != "native":
            continue
        tick, inside, rtf = r["controller_us"], r["kernel_us"], r["realtime_factor"]
        target = STANDING_TARGET if r["gait"] == "stand" else WALKING_TARGET
        slow = python.get((r["robot"], r["gait"], r["method"]))
        verdict = "**met**" if rtf >= target and not r["fell"] else "**not met**"
        python_p50, ratio = "-", "-"
        if slow is not None:
            over = tick["p50"] / slow > RATIO_TARGET
            python_p50 = f"{slow:.0f}"
            ratio = f"{tick['p50'] / slow:.3f}" + (f" (**> {RATIO_TARGET}**)" if over else "")
        lines.append(
            f"| {r['robot']} | {r['gait']} | {r['method']} | {tick['p50']:.0f} / "
            f"{tick['p99']:.0f} | {inside['p50']:.0f} / {inside['p99']:.0f} | {rtf:.2f}× | "
            f"{python_p50} | {ratio} | ≥ {target:.0f}×: {verdict} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path, help="`lab bench --json` outputs")
    args = parser.parse_args()
    print("\n".join(table_rows([json.loads(path.read_text()) for path in args.files])))


if __name__ == "__main__":
    main()
