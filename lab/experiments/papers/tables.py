"""What a generated table of docs/replications.md is: a paper's scenarios and each table's
columns, the measured ones read from the runs' reports beside the paper's numbers.

A table has row ids (a scenario's name, or a push's index for Herzog's Table 3) and columns;
a column's cell is computed from the row id and the reports of the paper's runs (flattened
as in a sweep table: `metrics.<key>`, `fell`, `sim_time_s`, ...). `lab report PAPER` runs the
scenarios and writes each table between its markers (report.py).
"""

from collections.abc import Callable, Mapping
from dataclasses import dataclass

Reports = Mapping[str, Mapping[str, object]]  # scenario name -> flattened report


@dataclass(frozen=True)
class Column:
    """A table column: its header and the text of its cell for a row id."""

    header: str
    cell: Callable[[object, Reports], str]


@dataclass(frozen=True)
class Table:
    """One generated table: its marker name in the docs, row ids, columns."""

    name: str
    rows: tuple[object, ...]
    columns: tuple[Column, ...]
    runs: tuple[str, ...] = ()  # the scenarios its cells read, when the rows are not them

    @property
    def scenarios(self) -> tuple[str, ...]:
        """The scenarios this table's cells read: `runs`, or else the rows themselves."""
        return self.runs or tuple(str(row) for row in self.rows)


@dataclass(frozen=True)
class Paper:
    """A paper's replication: the scenarios `lab report` runs and the tables they fill."""

    name: str
    scenarios: tuple[str, ...]
    tables: tuple[Table, ...]


def value(reports: Reports, scenario: str, key: str) -> float:
    """A number of a scenario's report (`metrics.` is prepended unless `key` is top-level)."""
    report = reports[scenario]
    return float(report[key] if key in report else report[f"metrics.{key}"])


def name_column(header: str = "run") -> Column:
    return Column(header, lambda row, _: f"`{row}`")


def given(header: str, texts: Mapping[object, str]) -> Column:
    """Text fixed per row: a description, or the paper's numbers."""
    return Column(header, lambda row, _: texts[row])


def measured(
    header: str, key: str, fmt: str, scale: float = 1.0, published: dict | None = None
) -> Column:
    """`key` of the row's scenario times `scale` in `fmt`, and the paper's number in brackets."""

    def cell(row: object, reports: Reports) -> str:
        text = format(scale * value(reports, str(row), key), fmt)
        return f"{text} ({published[row]})" if published else text

    return Column(header, cell)


def fell_column(header: str = "fell") -> Column:
    def cell(row: object, reports: Reports) -> str:
        report = reports[str(row)]
        return f"at {float(report['sim_time_s']):.2f} s" if report["fell"] else "no"

    return Column(header, cell)


def thousands(x: float) -> str:
    """29358.4 -> '29 358' (the docs' grouping)."""
    return f"{x:,.0f}".replace(",", " ")


def paper(name: str, *tables: Table) -> Paper:
    """A paper whose scenarios are those its tables read, each once, in the tables' order."""
    scenarios = dict.fromkeys(s for table in tables for s in table.scenarios)
    return Paper(name, tuple(scenarios), tables)
