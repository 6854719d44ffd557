"""WarningCapture: every warning raised inside a `with` block, recorded, for the session's tick.

The same as `warnings.catch_warnings(record=True)` with `warnings.simplefilter("always")`
inside, which the session entered every tick: on this project's machines that pair cost
~10-25 µs per tick (`git show fe8d29c:docs/performance.md`, round 8), more than the native
controller's Python around the kernel. This one swaps the warnings module's filters and hooks for a
prepared "always" filter and a list, and puts them back on exit: ~1 µs. Where the warnings module
lacks the hooks it swaps (a Python whose warnings module works differently), it falls back to
`catch_warnings`. Neither is thread-safe: like `catch_warnings`, it changes process-wide state
while the block runs.

The hooks are private, and stay (round 10): no public API does the job at that cost.
`catch_warnings(record=True)` is the public form of this very swap (its `__enter__` sets the
same `filters`, `_showwarnmsg_impl` and `showwarning` and calls `_filters_mutated`) plus a copy of
the filter list, and `simplefilter` adds a search of it: 3-4 µs against 0.7-1.1 µs here (minima
of 5 × 20,000 blocks, CPython 3.11). Replacing the documented hook `warnings.showwarning` alone
records nothing the filters drop ("once per location"), and putting the filters back needs the
module's `filters` list, itself outside `warnings.__all__`. Python 3.14 can keep the filters
per context instead (`sys.flags.context_aware_warnings`, on by default in free-threaded builds):
inside a `catch_warnings` block (pytest runs each test in one) the module's list is then not the
one in force, so there it falls back too.
"""

import sys
import warnings
from types import TracebackType

_ALWAYS = ("always", None, Warning, None, 0)  # warnings.simplefilter("always")'s filter entry
_HOOKS = ("filters", "showwarning", "_showwarnmsg_impl", "_showwarning_orig", "_filters_mutated")


def swaps_hooks(module: object = warnings, flags: object = sys.flags) -> bool:
    """Whether WarningCapture can swap the hooks of warnings `module` under interpreter `flags`:
    it has them all, and keeps its filters in the module, not per context."""
    has_hooks = all(hasattr(module, name) for name in _HOOKS)
    return has_hooks and not getattr(flags, "context_aware_warnings", False)


_SWAPS_HOOKS = swaps_hooks()


class WarningCapture:
    """A reusable context manager: `with capture as caught:` gives the list of
    `warnings.WarningMessage` raised in the block, each one (no "once per location" filtering).
    Not reentrant."""

    def __init__(self) -> None:
        self._saved: tuple | None = None
        self._fallback: warnings.catch_warnings | None = None

    def __enter__(self) -> list[warnings.WarningMessage]:
        if not _SWAPS_HOOKS:
            self._fallback = warnings.catch_warnings(record=True)
            caught = self._fallback.__enter__()
            warnings.simplefilter("always")
            return caught
        caught: list[warnings.WarningMessage] = []
        module = warnings
        self._saved = (module.filters, module.showwarning, module._showwarnmsg_impl)
        module.filters = [_ALWAYS]
        module._filters_mutated()
        module._showwarnmsg_impl = caught.append
        module.showwarning = module._showwarning_orig  # so that warn() calls the impl above
        return caught

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if self._fallback is not None:
            fallback, self._fallback = self._fallback, None
            fallback.__exit__(kind, error, traceback)
            return
        module = warnings
        module.filters, module.showwarning, module._showwarnmsg_impl = self._saved
        module._filters_mutated()
        self._saved = None
