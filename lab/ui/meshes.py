"""Visual geometry of a URDF as trimesh meshes, loaded once per file and cached.

Collada (.dae) files are decoded by trimesh through pycollada at load time; STL and OBJ directly.
Primitive shapes (box, sphere, cylinder) become trimesh primitives.
"""

import functools
from pathlib import Path

import numpy as np
import pinocchio as pin
import trimesh


@functools.lru_cache(maxsize=256)
def _mesh_file(path: str) -> trimesh.Trimesh:
    mesh = trimesh.load(path, force="scene").to_mesh()
    if isinstance(mesh.visual, trimesh.visual.TextureVisuals):
        # Per-vertex colours sampled from the texture: a textured GLB costs seconds of PNG encoding
        # per mesh on every load, vertex colours cost nothing.
        coloured = mesh.visual.to_color()
        if len(coloured.vertex_colors) == len(mesh.vertices):
            mesh.visual = coloured
        else:  # no usable texture coordinates: the material's main colour
            colour = mesh.visual.material.main_color
            mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=colour)
    return mesh


def geometry_mesh(geom: pin.GeometryObject) -> trimesh.Trimesh | None:
    """The mesh of one visual geometry in its own frame, coloured; None for unsupported shapes."""
    shape = geom.geometry
    kind = type(shape).__name__
    if kind == "Box":
        mesh = trimesh.creation.box(extents=2.0 * np.asarray(shape.halfSide))
    elif kind == "Sphere":
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=shape.radius)
    elif kind == "Cylinder":
        mesh = trimesh.creation.cylinder(radius=shape.radius, height=2.0 * shape.halfLength)
    elif kind == "Capsule":
        mesh = trimesh.creation.capsule(radius=shape.radius, height=2.0 * shape.halfLength)
    elif Path(geom.meshPath).suffix.lower() in (".dae", ".stl", ".obj"):
        mesh = _mesh_file(geom.meshPath).copy()
        mesh.apply_scale(np.asarray(geom.meshScale))
        if not geom.overrideMaterial and Path(geom.meshPath).suffix.lower() == ".dae":
            return mesh
    else:
        return None
    rgba = np.clip(np.asarray(geom.meshColor) * 255.0, 0, 255).astype(np.uint8)
    mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=np.tile(rgba, (len(mesh.faces), 1)))
    return mesh
