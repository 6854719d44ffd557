"""Talos's stack with the hands task (from tests/controller/test_hands.py)."""

# Herzog's Table 2 with the hands beside the momentum and the trunk, the posture a level below
# (beside them, weighted, the posture held the arms: the hand ended 8.6 cm short of 10).
HAND_STACK = [
    ["torque_limits"],
    ["contact", "cop_inner", "friction", "sole_torsion", "joint_limits"],
    ["momentum", "base_orientation", "hands"],
    ["posture", "forces"],
]
