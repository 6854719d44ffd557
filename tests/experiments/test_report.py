"""`lab report`: a paper's scenarios run as a sweep on Ray, their tables written between the
markers of a doc from the runs' reports (values, not timing), the rest of the doc untouched."""

import re
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest

from lab.experiments.expect import METRIC_KEYS, REPORT_FIELDS
from lab.experiments.papers import PAPERS
from lab.experiments.papers.tables import Paper, Table, fell_column, measured, name_column, value
from lab.experiments.report import (
    SCENARIOS,
    ReportError,
    failed_expectations,
    paper_sweep,
    render,
    reports_by_scenario,
    write_tables,
)
from lab.experiments.scenario import load_scenario
from lab.experiments.sweep.table import read_rows

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
    from lab.experiments.sweep.runner import run_sweep

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
    doc = (Path(__file__).resolve().parent.parent.parent / "docs" / "replications.md").read_text()
    for paper in PAPERS.values():
        sweep = paper_sweep(paper)
        assert [p.fields["scenario"] for p in sweep.points] == list(paper.scenarios)
        for table in paper.tables:
            assert f"<!-- lab report {table.name} -->" in doc
            assert f"<!-- end lab report {table.name} -->" in doc
            assert set(table.scenarios) <= set(paper.scenarios)


class DeclaredReport(Mapping[str, object]):
    """A scenario's flattened report holding exactly the keys its metrics declare
    (expect.METRIC_KEYS) and the report's own fields: reading any other key raises."""

    def __init__(self, scenario: str) -> None:
        loaded = load_scenario(SCENARIOS / f"{scenario}.toml")
        self.patterns = [re.compile(k) for name in loaded.metrics for k in METRIC_KEYS[name]]
        self.fields = {"fell": False, **dict.fromkeys(REPORT_FIELDS, loaded.duration)}

    def __getitem__(self, key: str) -> object:
        if key in self.fields:
            return self.fields[key]
        metric = key.removeprefix("metrics.")
        if key.startswith("metrics.") and any(p.fullmatch(metric) for p in self.patterns):
            return 0.5
        raise KeyError(key)

    def __contains__(self, key: object) -> bool:
        try:
            self[str(key)]
        except KeyError:
            return False
        return True

    def __iter__(self) -> Iterator[str]:
        return iter(self.fields)

    def __len__(self) -> int:
        return len(self.fields)


@pytest.mark.parametrize("paper", PAPERS.values(), ids=list(PAPERS))
def test_every_cell_reads_a_number_its_scenario_reports(paper: Paper) -> None:
    """A column naming a metric key that the scenario's metrics do not report (a typo, a
    renamed key) fails here, not after a campaign of runs."""
    reports = {name: DeclaredReport(name) for name in paper.scenarios}
    for table in paper.tables:
        lines = render(table, reports).splitlines()  # type: ignore[arg-type]
        assert len(lines) == 2 + len(table.rows)
        assert all(line.count("|") == len(table.columns) + 1 for line in lines)


def test_a_failed_run_is_not_written() -> None:
    rows = [{"point": "a", "scenario": "a", "error": "timeout: no result"}]
    with pytest.raises(ReportError, match="a: timeout"):
        reports_by_scenario(rows)


def test_an_unknown_paper_is_named_with_exit_2() -> None:
    from lab.experiments.report import report_main

    assert report_main(["no_such_paper"]) == 2
