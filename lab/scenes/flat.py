"""A flat floor at z = 0."""

from lab.scenes.geometry import TerrainGeom


def flat() -> tuple[TerrainGeom, ...]:
    return (TerrainGeom("floor", "plane", (0.0, 0.0, 1.0)),)
