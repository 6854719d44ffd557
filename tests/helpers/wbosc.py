"""Bolt's WBOSC stack (from tests/controller/test_wbosc.py)."""

BOLT_STACK = [
    ["friction", "torque_limits"],
    ["contact"],
    ["com"],
    ["base_orientation"],
    ["posture", "internal_force"],
]
