"""Suite-wide collection order: the browser tests first, the longest browser file first, then
the whole scenario runs.

`./dev test` runs the suite on two pytest-xdist workers, one test file at a time per worker
(`--dist loadfile`, in collection order). The browser files and the whole scenario runs
(tests/helpers/scenario_runs.py) are the longest; started first, they run beside the other files
instead of alone after them. A worker takes its next file when its current one has two tests or
fewer left to run, so the longest browser file (test_ui_browser.py: 1,451 s of wall time in a
loaded suite run, round 16, docs/reliability.md) goes first: after the one-test hand-gizmo file
it had started 70 s late.
"""

import pytest

from tests.helpers.browser import browser  # noqa: F401 (fixtures, for all)
from tests.helpers.ui import viser_server  # noqa: F401 (fixtures, for all)

# The browser files, longest first (a browser file not listed comes after these).
BROWSER_FILES = (
    "test_ui_browser.py",
    "test_page_lifecycle_browser.py",
    "test_bolt_browser.py",
    "test_hand_gizmo_browser.py",
)


def _browser_rank(item: pytest.Item) -> int:
    name = item.path.name
    return BROWSER_FILES.index(name) if name in BROWSER_FILES else len(BROWSER_FILES)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Move the tests marked `browser` to the front (BROWSER_FILES' order), then those marked
    `scenario_run`, keeping the order within each part."""
    items.sort(
        key=lambda item: (
            item.get_closest_marker("browser") is None,
            _browser_rank(item),
            item.get_closest_marker("scenario_run") is None,
        )
    )
