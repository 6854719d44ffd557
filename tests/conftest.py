"""Suite-wide collection order: the browser tests first.

`./dev test` runs the suite on two pytest-xdist workers, one test file at a time per worker
(`--dist loadfile`, in collection order). The browser file is the longest; started first, it runs
beside the other files instead of alone after them.
"""

import pytest


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Move the tests marked `browser` to the front, keeping the order within each part."""
    items.sort(key=lambda item: item.get_closest_marker("browser") is None)
