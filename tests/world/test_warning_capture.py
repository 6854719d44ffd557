"""WarningCapture, the session's per-tick record of warnings: every warning of the block, the
warnings module as it was afterwards."""

import sys
import types
import warnings

import pytest

from lab.world import warning_capture
from lab.world.warning_capture import WarningCapture, swaps_hooks


@pytest.fixture(params=["hooks", "catch_warnings"])
def way(request, monkeypatch) -> str:
    """Each test on both ways: the swapped hooks, and the `catch_warnings` fallback."""
    if request.param == "catch_warnings":
        monkeypatch.setattr(warning_capture, "_SWAPS_HOOKS", False)
    return request.param


def _warn(message: str) -> None:
    warnings.warn(message, RuntimeWarning, stacklevel=1)  # one location for every call


@pytest.mark.usefixtures("way")
def test_every_warning_of_the_block_is_recorded_each_time() -> None:
    capture = WarningCapture()
    for tick in range(3):
        with capture as caught:
            _warn(f"tick {tick} a")
            _warn(f"tick {tick} b")  # the same location again: "always", not "once"
        assert [str(w.message) for w in caught] == [f"tick {tick} a", f"tick {tick} b"]
        assert all(w.category is RuntimeWarning for w in caught)


@pytest.mark.usefixtures("way")
def test_the_warnings_module_is_restored_even_after_an_error() -> None:
    capture = WarningCapture()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # outside the block, warnings are ignored
        filters, showwarning = warnings.filters, warnings.showwarning
        with pytest.raises(ZeroDivisionError), capture as caught:
            _warn("inside")
            1 / 0  # noqa: B018
        assert [str(w.message) for w in caught] == ["inside"]
        assert warnings.filters is filters and warnings.showwarning is showwarning
        with warnings.catch_warnings(record=True) as outside:
            warnings.simplefilter("ignore")
            _warn("outside")
        assert outside == []  # the filters outside hold again


def test_the_hooks_are_swapped_only_where_the_module_keeps_its_filters() -> None:
    """CPython 3.11-3.13: yes. A warnings module without one of the hooks, or Python 3.14's
    context-aware warnings (filters per context, not in the module's list): the fallback."""
    assert swaps_hooks(warnings, types.SimpleNamespace())
    assert not swaps_hooks(warnings, types.SimpleNamespace(context_aware_warnings=True))
    assert not swaps_hooks(types.SimpleNamespace(filters=[], showwarning=print), sys.flags)
