"""`lab report`: a paper's scenarios run as a sweep on Ray, their tables written between the
markers of a doc from the runs' reports (values, not timing), the rest of the doc untouched."""

from pathlib import Path

import pytest

from lab.sweep.papers import PAPERS, Paper, Table, fell_column, measured, name_column, value
from lab.sweep.report import (
    SCENARIOS,
    ReportError,
    failed_expectations,
    paper_sweep,
    render,
    reports_by_scenario,
    write_tables,
)
from lab.sweep.table import read_rows

STAND = """robot = "solo12"
duration = 0.3
[expect]
fell = false
max_base_height_error_m = { max = 0.01 }
"""
DOC = """# Title
Before.
<!-- lab report tiny -->
| old | table |
<!-- end lab report tiny -->
After.
"""


def test_a_small_report_writes_the_runs_values_between_the_markers(tmp_path: Path) -> None:
    from lab.sweep.runner import run_sweep

    (tmp_path / "tiny_stand.toml").write_text(STAND)
    table = Table(
        "tiny",
        ("tiny_stand",),
        (
            name_column(),
            fell_column(),
            measured("height error [mm]", "max_base_height_error_m", ".3f", 1e3),
        ),
    )
    paper = Paper("tiny", ("tiny_stand",), (table,))
    output = tmp_path / "tiny.csv"
    outcome = run_sweep(paper_sweep(paper, tmp_path), output, workers=1, progress=False)
    assert (outcome.ok, outcome.failed) == (1, 0)
    reports = reports_by_scenario(read_rows(output))
    assert set(reports) == {"tiny_stand"} and failed_expectations(reports) == []
    assert reports["tiny_stand"]["expect.passed"] is True
    height = value(reports, "tiny_stand", "max_base_height_error_m")
    assert 0 < height < 0.01
    doc = tmp_path / "doc.md"
    doc.write_text(DOC)
    write_tables(doc, {"tiny": render(table, reports)})
    expected = (
        "| run | fell | height error [mm] |\n|---|---|---|\n"
        f"| `tiny_stand` | no | {1e3 * height:.3f} |"
    )
    assert doc.read_text() == DOC.replace("| old | table |", expected)
    write_tables(doc, {"tiny": render(table, reports)})  # idempotent: markers kept
    assert doc.read_text() == DOC.replace("| old | table |", expected)
    with pytest.raises(ReportError, match="'absent'"):
        write_tables(doc, {"absent": "x"})


def test_every_paper_table_has_its_markers_and_scenarios() -> None:
    doc = (Path(__file__).resolve().parent.parent / "docs" / "replications.md").read_text()
    for paper in PAPERS.values():
        sweep = paper_sweep(paper)
        assert [p.fields["scenario"] for p in sweep.points] == list(paper.scenarios)
        for table in paper.tables:
            assert f"<!-- lab report {table.name} -->" in doc
            assert f"<!-- end lab report {table.name} -->" in doc
            assert all((SCENARIOS / f"{row}.toml").exists() for row in table.rows)


def test_a_failed_run_is_not_written() -> None:
    rows = [{"point": "a", "scenario": "a", "error": "timeout: no result"}]
    with pytest.raises(ReportError, match="a: timeout"):
        reports_by_scenario(rows)


def test_an_unknown_paper_is_named_with_exit_2() -> None:
    from lab.sweep.report import report_main

    assert report_main(["no_such_paper"]) == 2
