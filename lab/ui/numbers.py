"""Numbers typed into the panel: parsed exactly as typed and checked against the lab's limits, so
that a value out of range is refused with a message naming the limit instead of being clamped or
converted silently (pure logic, tested in tests/ui/test_ui_logic.py)."""

import math
from dataclasses import dataclass


class NumberError(ValueError):
    """A typed number that is not a number, not finite, or outside its range; says which."""


@dataclass(frozen=True)
class NumberRange:
    """What a field accepts: lo ≤ x ≤ hi (lo < x when `lo_open`), in `unit`."""

    label: str
    lo: float
    hi: float
    unit: str = ""
    lo_open: bool = False

    def describe(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        low = "> " if self.lo_open else "≥ "
        return f"{low}{self.lo:g}{unit} and ≤ {self.hi:g}{unit}"

    def check(self, value: float) -> float:
        """`value` itself if it is finite and in range; NumberError naming the limit otherwise."""
        unit = f" {self.unit}" if self.unit else ""
        if not math.isfinite(value):
            raise NumberError(f"{self.label} must be a finite number, got {value}")
        if value > self.hi:
            raise NumberError(
                f"{self.label} = {value:g}{unit} is above the limit {self.hi:g}{unit}"
            )
        if value < self.lo or (self.lo_open and value == self.lo):
            bound = "must be above" if self.lo_open else "is below the limit"
            raise NumberError(f"{self.label} = {value:g}{unit} {bound} {self.lo:g}{unit}")
        return value

    def parse(self, text: str) -> float:
        """The number written in `text` (Python float syntax: "1e9", "-5", "0.001")."""
        try:
            value = float(text.strip())
        except ValueError:
            raise NumberError(f"{self.label}: {text.strip()!r} is not a number") from None
        return self.check(value)


def format_number(value: float) -> str:
    """The text a number box shows for `value`: short, and parsed back to exactly `value`."""
    short = f"{value:g}"
    return short if float(short) == value else repr(float(value))
