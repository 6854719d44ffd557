"""Benchmark of the loop's three wake-up settings side by side (not a test; issue 31, item 3):
the default (a fixed 0.05 ms spin), `--spin-ms 1` (the whole period: never sleeps) and `--spin-ms
auto` (the adaptive margin, lab/runtime/wake_margin.py).

    .venv/bin/python benchmarks/bench_spin.py --rounds 2 --duration 20 [--json]

The settings take turns within each round (default, 1, auto, then again), so all three see the
same load on a shared machine. Each turn is two runs:
- `bench_server.py --ui --gait trot --no-floor` (ANYmal trotting with the UI process and two
  subscribers): on-time fraction, command latency p99, the loop thread's CPU share;
- `bench_starvation.py` (Debian's headless Chromium on the page): the clicks' p50 / p90 and the
  on-time fraction and CPU share meanwhile.
The report is the median over the rounds of each figure, per setting, with the machine's load at
the start and end.
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from statistics import median

HERE = Path(__file__).resolve().parent
SETTINGS = ("default", "1", "auto")  # the `--spin-ms` of each ("default": the server's own)


def run(script: str, setting: str, *extra: str) -> dict:
    """One benchmark run with `setting`'s spin, its JSON report."""
    cmd = [sys.executable, str(HERE / script), "--json", *extra]
    if setting != "default":
        cmd += ["--spin-ms", setting]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--rounds", type=int, default=2, help="turns of each setting (default: 2)")
    p.add_argument("--duration", type=float, default=20.0, help="s per server run (default: 20)")
    p.add_argument("--actions", type=int, default=20, help="clicks per run (default: 20)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args()
    if args.rounds < 1:
        p.error("--rounds must be at least 1")
    load = [round(os.getloadavg()[0], 1)]
    runs: dict[str, list[tuple[dict, dict]]] = {s: [] for s in SETTINGS}
    for _ in range(args.rounds):
        for setting in SETTINGS:
            server = run(
                "bench_server.py",
                setting,
                *("--ui", "--gait", "trot", "--no-floor", "--duration", str(args.duration)),
            )
            clicks = run("bench_starvation.py", setting, "--actions", str(args.actions))
            runs[setting].append((server, clicks))
    load.append(round(os.getloadavg()[0], 1))
    table = {setting: summarize(pairs) for setting, pairs in runs.items()}
    if args.json:
        print(json.dumps({"load": load, "rounds": args.rounds, "settings": table}))
        return 0
    print(f"{args.rounds} rounds, load {load[0]} at the start, {load[1]} at the end")
    print(
        "| `--spin-ms` | on time, trotting | latency p99 | loop CPU | click p50 / p90 | "
        "on time, browser | loop CPU, browser |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for setting, r in table.items():
        print(
            f"| {setting} | {r['on_time']:.3%} | {r['latency_p99_ms']:.2f} ms | "
            f"{r['cpu']:.1%} | {r['click_p50_ms']:.1f} / {r['click_p90_ms']:.1f} ms | "
            f"{r['browser_on_time']:.3%} | {r['browser_cpu']:.1%} |"
        )
    return 0


def summarize(pairs: list[tuple[dict, dict]]) -> dict[str, float]:
    """The median over the rounds of each figure of one setting."""
    return {
        "on_time": median(s["on_time_fraction"] for s, _ in pairs),
        "latency_p99_ms": median(s["latency_ms"]["p99"] for s, _ in pairs),
        "cpu": median(s["loop_cpu_share"] for s, _ in pairs),
        "click_p50_ms": median(c["click_ms"]["p50"] for _, c in pairs),
        "click_p90_ms": median(c["click_ms"]["p90"] for _, c in pairs),
        "browser_on_time": median(c["on_time_fraction"] for _, c in pairs),
        "browser_cpu": median(c["loop_cpu_share"] for _, c in pairs),
    }


if __name__ == "__main__":
    sys.exit(main())
