"""The gaits the panel offers for driving: `stand`, `trot`, `crawl` (quadrupeds) and
`biped_step` (two point feet, Kim 2016) from `info["gaits"]`.

The other behaviours in `info["gaits"]` are Hutter 2014's scripted experiments (see
docs/replications.md); they run from scenarios and stay out of the driving dropdown.
"""

DRIVING_GAITS = ("stand", "trot", "crawl", "biped_step")


def gait_options(gaits: list[str], current: str) -> tuple[str, ...]:
    """The dropdown's options: the driving gaits the server offers, in `DRIVING_GAITS` order, and
    the current gait after them if it is another behaviour, so the dropdown shows what runs."""
    options = tuple(name for name in DRIVING_GAITS if name in gaits)
    return options if current in options else (*options, current)
