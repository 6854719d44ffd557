"""A kept world's MjModel copied for a switch (lab/world/compiled.py `copied_model`, through
`lab._plant.copy_model` without the GIL when it is built): the copy is the kept model, bit for
bit and step for step, it is its own struct, and MuJoCo's binding frees it with its object."""

import gc

import mujoco
import numpy as np
import pytest

from lab.world.compiled import compile_world, copied_model, world_key
from lab.world.memory import heap_usage
from lab.world.plant import _plant

STEPS = 20
COPIES = 40  # made and dropped: ~300 MB of Solo12 models if none were freed


@pytest.fixture(scope="module")
def kept() -> mujoco.MjModel:
    """Solo12 on rough terrain (meshes, terrain geoms, a seed): a kept world's model."""
    return compile_world(world_key("solo12", "rough", 1e-3, 3)).mj_model


def _stepped(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """(qpos, qvel) after STEPS MuJoCo steps from the model's reference pose under fixed
    torques."""
    data = mujoco.MjData(model)
    data.qpos[2] += 0.3  # above the ground: it falls and lands
    data.ctrl[:] = 0.5 * np.sin(np.arange(model.nu))
    for _ in range(STEPS):
        mujoco.mj_step(model, data)
    return data.qpos.copy(), data.qvel.copy()


def test_a_copied_model_is_the_kept_one_and_its_own(kept: mujoco.MjModel) -> None:
    """Sizes, arrays and STEPS steps equal to the bit; another struct, whose change (a mass)
    leaves the kept model as it was."""
    copied = copied_model(kept)
    assert copied._address != kept._address
    assert mujoco.mj_sizeModel(copied) == mujoco.mj_sizeModel(kept)
    sizes = ("nq", "nv", "nu", "nbody", "ngeom", "nmesh", "nmeshvert", "nhfield", "nbuffer")
    assert [getattr(copied, n) for n in sizes] == [getattr(kept, n) for n in sizes]
    for field in ("body_mass", "body_inertia", "geom_size", "geom_pos", "mesh_vert", "hfield_data"):
        np.testing.assert_array_equal(getattr(copied, field), getattr(kept, field), err_msg=field)
    q0, v0 = _stepped(kept)
    q, v = _stepped(copied)
    np.testing.assert_array_equal(q, q0)
    np.testing.assert_array_equal(v, v0)
    assert np.linalg.norm(v0) > 0.01  # the steps moved the robot: they compared something
    mass = kept.body_mass[1]
    copied.body_mass[1] += 5.0
    assert kept.body_mass[1] == mass


@pytest.mark.skipif(_plant is None, reason="lab._plant is not built")
def test_the_native_copy_outlives_its_source_and_is_freed_with_its_object() -> None:
    """The struct `lab._plant.copy_model` makes belongs to MuJoCo's binding (cpp/plant/plant.cpp):
    it runs after its source is gone, and COPIES copies made and dropped leave the C heap's
    memory in use within one model of where it was (a struct nobody freed: COPIES models)."""
    source = compile_world(world_key("solo12", "flat", 1e-3, None)).mj_model
    size_mb = mujoco.mj_sizeModel(source) / 2**20
    assert size_mb > 5.0  # Solo12's meshes: a leak of COPIES models would be hundreds of MB
    q0, v0 = _stepped(source)
    copied = _plant.copy_model(source)
    del source
    gc.collect()
    q, v = _stepped(copied)
    np.testing.assert_array_equal(q, q0)
    np.testing.assert_array_equal(v, v0)
    before = heap_usage()
    if before is None:
        pytest.skip("no glibc mallinfo2 to read the heap with")
    for _ in range(COPIES):  # two copies made a round, the last one kept
        copied = _plant.copy_model(copied_model(copied))
    gc.collect()
    after = heap_usage()
    assert after is not None
    assert after["in_use"] - before["in_use"] < size_mb, (before, after, size_mb)
