"""`lab sweep`: parameter sweeps of headless scenarios run as Ray tasks (spec.py: the sweep file
and its points; runner.py: Ray; table.py: the results CSV; plot.py: the push-recovery map)."""
