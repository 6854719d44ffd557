"""Suite-wide collection order: the browser tests first, then the whole scenario runs.

`./dev test` runs the suite on two pytest-xdist workers, one test file at a time per worker
(`--dist loadfile`, in collection order). The browser files and the whole scenario runs
(tests/helpers/scenario_runs.py) are the longest; started first, they run beside the other files
instead of alone after them.
"""

import pytest

from tests.helpers.ui import viser_server  # noqa: F401 (fixtures, for all)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Move the tests marked `browser` to the front, then those marked `scenario_run`, keeping
    the order within each part."""
    items.sort(
        key=lambda item: (
            item.get_closest_marker("browser") is None,
            item.get_closest_marker("scenario_run") is None,
        )
    )
