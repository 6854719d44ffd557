"""Shipped scenarios run to their end, their [expect] checked: group 2
(tests/helpers/scenario_runs.py)."""

from pathlib import Path

import pytest

from tests.helpers.scenario_runs import group, run_and_check


@pytest.mark.scenario_run
@pytest.mark.parametrize("path", group(2))
def test_the_whole_run_meets_its_expectation(path: Path) -> None:
    run_and_check(path)
