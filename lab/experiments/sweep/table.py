"""The results table of a sweep: one CSV row per point.

A row holds `point` (the point's key, see spec.py), every varied field under its own name,
`error` (empty when the run finished, else what went wrong: an exception, a timeout, a lost
worker) and every entry of the point's `lab run --json` report, nested keys joined with dots
(`metrics.cog_error_max_m`, `tick_us.p99`). Cells are JSON (`true`, `[0.0, 150.0, 0.0]`,
`123.4`) except strings, which are written plainly. The file is rewritten whole (to a temporary
file, then renamed) after every finished point, so an interrupted sweep keeps what finished.
"""

import csv
import json
import os
from pathlib import Path

KEY = "point"
ERROR = "error"


def flatten(report: dict, prefix: str = "") -> dict[str, object]:
    """A nested report as one level of dotted keys."""
    flat: dict[str, object] = {}
    for key, value in report.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def result_row(key: str, fields: dict[str, object], report: dict | None, error: str) -> dict:
    """The row of a point: its key and fields, its error (or ""), its flattened report."""
    return {KEY: key, **fields, ERROR: error, **flatten(report or {})}


def read_rows(path: str | Path) -> list[dict[str, object]]:
    """The rows of a results file (none if it does not exist), cells decoded."""
    path = Path(path)
    if not path.exists():
        return []
    with path.open(newline="") as file:
        return [_decoded(row) for row in csv.DictReader(file)]


def write_rows(path: str | Path, rows: list[dict[str, object]]) -> None:
    """Write all rows (columns: the union of the rows' keys, first-seen order), atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    columns = list(dict.fromkeys(key for row in rows for key in row))
    temporary = path.with_name(f".{path.name}.tmp")
    with temporary.open("w", newline="") as file:
        writer = csv.DictWriter(file, columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({key: _encode(value) for key, value in row.items()})
    os.replace(temporary, path)


def _decoded(row: dict[str, str]) -> dict[str, object]:
    """A CSV row's cells as values; the key and the error stay text, empty cells are left out."""
    decoded = {key: _decode(cell) for key, cell in row.items() if cell != ""}
    return decoded | {KEY: row[KEY], ERROR: row.get(ERROR) or ""}


def _encode(value: object) -> str:
    return value if isinstance(value, str) else json.dumps(value)


def _decode(cell: str) -> object:
    try:
        return json.loads(cell)
    except ValueError:
        return cell
