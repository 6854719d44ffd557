"""`lab report PAPER`: run a paper's scenarios as a sweep (Ray, locally or on a cluster) and write
its tables into docs/replications.md between their markers, so they come from runs:

    <!-- lab report hutter_table5 -->
    | run | ... |             (replaced by every `lab report hutter`)
    <!-- end lab report hutter_table5 -->

Each scenario runs whole, its `[expect]` checked (the report says which failed).
"""

import argparse
import re
import sys
import tomllib
from pathlib import Path

from lab.experiments.papers import PAPERS
from lab.experiments.papers.tables import Paper, Table
from lab.experiments.sweep.spec import Point, Sweep
from lab.experiments.sweep.table import ERROR, read_rows

ROOT = Path(__file__).resolve().parent.parent.parent
SCENARIOS = ROOT / "scenarios"
DOC = ROOT / "docs" / "replications.md"
OUTPUT_DIR = Path("out/reports")
TIMEOUT_S = 3600.0  # wall time a scenario may take (a long one on a busy machine: minutes)


class ReportError(ValueError):
    """A paper, scenario or marker that is not there; the message names it."""


def paper_sweep(paper: Paper, scenarios: Path = SCENARIOS) -> Sweep:
    """The sweep of a paper's scenarios: one point each, field `scenario`, run unchanged."""
    sweep = Sweep(f"report_{paper.name}", scenarios, timeout=TIMEOUT_S)
    sweep.fields = ["scenario"]
    for name in paper.scenarios:
        path = scenarios / f"{name}.toml"
        if not path.exists():
            raise ReportError(f"paper {paper.name}: no scenario {path}")
        data = tomllib.loads(path.read_text())
        data.setdefault("name", name)
        sweep.points.append(Point({"scenario": name}, data))
    return sweep


def reports_by_scenario(rows: list[dict]) -> dict[str, dict]:
    """The flattened reports of a results table, by scenario; an error row raises."""
    failed = [f"{row['scenario']}: {row[ERROR]}" for row in rows if row[ERROR]]
    if failed:
        raise ReportError("runs failed: " + "; ".join(failed))
    return {str(row["scenario"]): row for row in rows}


def render(table: Table, reports: dict[str, dict]) -> str:
    """A table as Markdown."""
    lines = [
        "| " + " | ".join(c.header for c in table.columns) + " |",
        "|" + "|".join("---" for _ in table.columns) + "|",
    ]
    for row in table.rows:
        lines.append("| " + " | ".join(c.cell(row, reports) for c in table.columns) + " |")
    return "\n".join(lines)


def write_tables(doc: Path, tables: dict[str, str]) -> None:
    """Replace what stands between each table's markers in `doc` (a marker missing raises)."""
    text = doc.read_text()
    for name, body in tables.items():
        pattern = re.compile(
            rf"(<!-- lab report {re.escape(name)} -->\n).*?(<!-- end lab report "
            rf"{re.escape(name)} -->)",
            re.DOTALL,
        )
        if not pattern.search(text):
            raise ReportError(f"{doc}: no markers for table {name!r}")
        text = pattern.sub(lambda m, body=body: m.group(1) + body + "\n" + m.group(2), text)
    doc.write_text(text)


def failed_expectations(reports: dict[str, dict]) -> list[str]:
    """The scenarios whose [expect] did not hold."""
    return [name for name, r in reports.items() if r.get("expect.passed") is False]


def report_main(argv: list[str]) -> int:
    """`lab report PAPER [--workers N | --address HOST:PORT] [--doc FILE] [--resume]`."""
    parser = argparse.ArgumentParser(
        prog="lab report",
        description="Run a paper's scenarios (as a sweep on Ray) and write its tables into "
        "docs/replications.md between their markers.",
    )
    parser.add_argument("paper", help=f"one of {', '.join(PAPERS)}")
    parser.add_argument("--workers", type=int, help="tasks at a time (default: the cores)")
    parser.add_argument("--address", help="an existing Ray cluster (HOST:PORT)")
    parser.add_argument("--doc", type=Path, default=DOC, help=f"the file to write ({DOC.name})")
    parser.add_argument("--output", help=f"results table (default {OUTPUT_DIR}/<paper>.csv)")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="keep the runs already in the table (an interrupted report); default: rerun all",
    )
    args = parser.parse_args(argv)
    if args.paper not in PAPERS:
        print(
            f"lab report: unknown paper {args.paper!r} (known: {', '.join(PAPERS)})",
            file=sys.stderr,
        )
        return 2
    paper = PAPERS[args.paper]
    output = Path(args.output or OUTPUT_DIR / f"{paper.name}.csv")
    if not args.resume:
        output.unlink(missing_ok=True)  # every table from this run, none from an older one
    from lab.experiments.sweep.runner import RayUnavailable, run_sweep

    try:
        run_sweep(paper_sweep(paper), output, args.workers, args.address)
        reports = reports_by_scenario(read_rows(output))
        write_tables(args.doc, {t.name: render(t, reports) for t in paper.tables})
    except (ReportError, RayUnavailable) as error:
        print(f"lab report: {error}", file=sys.stderr)
        return 2 if isinstance(error, RayUnavailable) else 1
    failed = failed_expectations(reports)
    for name in failed:
        print(f"lab report: {name}: its [expect] did not hold (see {output})", file=sys.stderr)
    print(f"{paper.name}: {len(paper.tables)} tables written to {args.doc} from {output}")
    return 1 if failed else 0
