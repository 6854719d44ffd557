"""The hypothesis strategies of every protocol verb (from tests/runtime/test_fuzz.py)."""

import math

from hypothesis import strategies as st

from lab.controller.tasks import TASK_TYPES
from lab.description import ROBOT_NAMES
from lab.protocol import VERBS
from lab.scenes import SCENES

leaves = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**40), max_value=10**40)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=40)
)
json_values = st.recursive(
    leaves,
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=12), inner),
    max_leaves=16,
)


def deep(depth: int) -> list:
    value: list = []
    for _ in range(depth):
        value = [value]
    return value


numbers = st.floats(min_value=-1e4, max_value=1e4) | st.sampled_from(
    [0.0, -5.0, 1e9, 1e300, math.inf, -math.inf, math.nan, 10**400]
)
vectors = st.lists(numbers, min_size=3, max_size=3)
# Valid robot and scene names are left out: each rebuilds the session (a second or so), and a
# switch is covered by its own tests. `nullspace` is left out of the methods for the same reason
# (tens of ms per tick while walking).
names = st.text(max_size=20).filter(lambda s: s not in ROBOT_NAMES and s not in SCENES)
FIELD_VALUES = {
    "vx": numbers,
    "vy": numbers,
    "yaw_rate": numbers,
    "body": st.sampled_from(["base", "base_link", "LF_FOOT", "nope"]) | names,
    "force": vectors,
    "point": vectors,
    "duration": numbers,
    "name": st.sampled_from(["stand", "trot", "crawl"]) | names,
    "method": st.sampled_from(["cascade", "weighted", "wbosc"]) | names,
    "solver": st.sampled_from(["daqp", "clarabel", "osqp"]) | names,
    "formulation": st.sampled_from(["qdd_force", "full", "banana"]),
    "levels": st.lists(st.lists(st.sampled_from([*TASK_TYPES, "friction", "x"]), max_size=4)),
    "preset": st.sampled_from(["raiola_s3", "raiola_s1", "hutter_table7", "nope"]),
    "task": st.sampled_from([*TASK_TYPES, "nope"]),
    "kp": numbers,
    "kd": numbers,
    "weight": numbers,
    "step_height": numbers,
    "cycle_time": numbers,
    "footholds": st.sampled_from(["raiola", "raibert", "other"]),
    "mode": st.sampled_from(["pd", "lqr", "pid"]),
}
verbs = st.sampled_from(VERBS) | st.text(max_size=12)
field_names = st.lists(st.sampled_from(sorted(FIELD_VALUES)), max_size=4, unique=True)
