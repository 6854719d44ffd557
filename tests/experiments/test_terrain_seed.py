"""`terrain_seed`: a scenario field (so a sweep field) that draws the random terrain of `rough`,
from the scenario down to the MuJoCo model; refused for a scene with nothing to seed."""

from pathlib import Path

import numpy as np
import pytest

from lab.experiments.scenario import ScenarioError, parse_scenario
from lab.experiments.sweep.spec import check_scenario, load_sweep
from lab.scenes import scene_geoms
from lab.scenes.rough import MAX_HEIGHT, SEED
from lab.world.session import Session, SessionConfig

ROUGH = Path(__file__).resolve().parent.parent.parent / "scenarios" / "anymal_trot_rough.toml"


def _tops(geoms) -> np.ndarray:
    """The top heights of the rough scene's tiles (m)."""
    return np.array([g.position[2] + g.size[2] for g in geoms if g.name.startswith("tile_")])


def test_the_seed_draws_the_tiles_and_the_default_is_the_old_terrain() -> None:
    default, same, other = (_tops(scene_geoms("rough", s)) for s in (None, SEED, 11))
    assert np.array_equal(default, same)
    assert len(other) == len(default) and np.abs(other - default).max() > 0.01
    assert other.min() >= 0.0 and other.max() <= MAX_HEIGHT + 1e-12
    assert scene_geoms("flat", 3) == scene_geoms("flat")  # nothing to seed


def test_a_sweep_over_seeds_reaches_the_simulated_ground(tmp_path: Path) -> None:
    sweep = tmp_path / "seeds.toml"
    sweep.write_text(f'base = "{ROUGH}"\n[grid]\nterrain_seed = [1, 2]\n')
    points = load_sweep(sweep).points
    assert [p.fields for p in points] == [{"terrain_seed": 1}, {"terrain_seed": 2}]
    config = check_scenario(points[1].scenario, ROUGH).config
    assert (config.scene, config.terrain_seed) == ("rough", 2)
    # the MuJoCo model has the tiles of that seed (Bolt: the lightest robot to build)
    session = Session(SessionConfig(robot="bolt", scene="rough", terrain_seed=2))
    model = session.plant.mj_model
    expected = {g.name: g.position[2] + g.size[2] for g in scene_geoms("rough", 2)}
    for name in ("tile_0_0", "tile_7_3", "tile_39_9"):
        geom = model.geom(name)
        assert geom.pos[2] + geom.size[2] == pytest.approx(expected[name], abs=1e-9)


@pytest.mark.parametrize(
    ("fields", "error"),
    [
        ({"scene": "flat", "terrain_seed": 1}, "scene 'flat' has no random terrain"),
        ({"scene": "rough", "terrain_seed": -1}, "non-negative integer"),
        ({"scene": "rough", "terrain_seed": 1.5}, "non-negative integer"),
        ({"scene": "rough", "terrain_seed": True}, "non-negative integer"),
    ],
)
def test_a_seed_that_cannot_be_used_is_refused(fields: dict, error: str) -> None:
    with pytest.raises(ScenarioError, match=error):
        parse_scenario({"duration": 1.0, **fields}, Path("s.toml"))
