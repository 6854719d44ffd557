"""Headless experiments: scenarios and their limits and [expect], the per-tick metrics (metrics/),
`lab bench`, `lab soak`, `lab robot new | check`, `lab sweep` (sweep/) and `lab report`."""
