"""An axis range computed here for uPlot charts whose series have NaN gaps.

uPlot (1.6.x, as viser ships it) starts each series' min/max at its first non-null value in view,
and NaN is not null: a series whose first value is NaN gets a NaN range, the y scale becomes
NaN, and the chart draws no points and no y axis. viser sends the data as Float64Array, which
cannot hold uPlot's null gaps, so a chart with NaN gaps is given its y range (a fixed tuple)
from the finite values instead. The range changes only when the data leave it or fill less than
a third of it (a fresh range is at most 2.4 times the data's span), so that it does not jitter
with every redraw.
"""

import math

import numpy as np

PAD = 0.1  # of the data's span, each side


def nice_step(span: float) -> float:
    """1, 2 or 5 × 10ⁿ, about a fifth of `span` (> 0): the grid the range's ends snap to."""
    raw = span / 5.0
    decade = 10.0 ** math.floor(math.log10(raw))
    return next(m * decade for m in (1.0, 2.0, 5.0, 10.0) if m * decade >= raw)


def axis_range(
    values: np.ndarray, current: tuple[float, float] | None, min_span: float
) -> tuple[float, float]:
    """The axis range (low, high) to show `values` (NaN ignored; the y values of a chart, or the
    x values of a phase portrait), at least `min_span` (> 0) wide:
    `current` while the finite values fit in it and span more than a third of it, otherwise their
    extent padded by PAD, its ends snapped outwards to a `nice_step`. With no finite value,
    `current`, or ±min_span/2."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return current if current is not None else (-0.5 * min_span, 0.5 * min_span)
    lo, hi = float(finite.min()), float(finite.max())
    if current is not None:
        c_lo, c_hi = current
        if c_lo <= lo and hi <= c_hi and 3.0 * max(hi - lo, min_span) > c_hi - c_lo:
            return current
    span = max(hi - lo, min_span)
    mid = 0.5 * (lo + hi)
    lo, hi = mid - 0.5 * span * (1 + 2 * PAD), mid + 0.5 * span * (1 + 2 * PAD)
    step = nice_step(hi - lo)
    return math.floor(lo / step) * step, math.ceil(hi / step) * step
