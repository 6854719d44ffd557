"""Visual geometry of a URDF as trimesh meshes, converted once per file and cached on disk.

Collada (.dae) files are decoded by trimesh through pycollada, STL and OBJ directly; textures are
baked to colours. That conversion cost ANYmal 8–24 s of CPU on a busy 2-core machine, so each
converted mesh (vertices, faces, colours) is kept in `cache_dir()` under the SHA-256 of the source
file and of the conversion's version: later loads read arrays. Primitive shapes (box, sphere,
cylinder) become trimesh primitives.

Meshes are decimated when converted (quadric decimation, `fast_simplification` through trimesh):
a browser without a GPU renders every triangle in software, and ANYmal's 58k and Talos's 159k
faces kept a busy machine's page faded for up to a minute and every redraw slow. A mesh keeps
DECIMATE_KEEP of its faces (at least DECIMATE_FLOOR); colours follow to the nearest vertex.
"""

import functools
import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from lab.urdf_visuals import DEFAULT_RGBA, Visual

CONVERSION_VERSION = b"lab.ui.meshes 3"  # change when _convert changes: old entries are not read
DECIMATE_KEEP = 0.15  # fraction of a mesh's faces drawn
DECIMATE_FLOOR = 300  # faces: a mesh this small or smaller is drawn as it is


def cache_dir() -> Path:
    """`$LAB_MESH_CACHE`, else `$XDG_CACHE_HOME/wbc-lab/meshes` (default ~/.cache)."""
    if "LAB_MESH_CACHE" in os.environ:
        return Path(os.environ["LAB_MESH_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "wbc-lab" / "meshes"


def _cache_file(path: str) -> Path:
    digest = hashlib.sha256(CONVERSION_VERSION)
    digest.update(Path(path).suffix.lower().encode())
    digest.update(Path(path).read_bytes())
    return cache_dir() / f"{digest.hexdigest()}.npz"


def _save(mesh: trimesh.Trimesh, file: Path) -> None:
    """Write atomically (a reader never sees half a file); a cache that cannot be written is
    reported and skipped."""
    arrays = {"vertices": mesh.vertices, "faces": mesh.faces}
    kind = mesh.visual.kind if isinstance(mesh.visual, trimesh.visual.ColorVisuals) else None
    if kind == "vertex":
        arrays["vertex_colors"] = mesh.visual.vertex_colors
    elif kind == "face":
        arrays["face_colors"] = mesh.visual.face_colors
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=file.parent, suffix=".tmp", delete=False) as out:
            np.savez(out, **arrays)
        os.replace(out.name, file)
    except OSError as error:
        print(f"lab ui: mesh cache not written ({error}); meshes are converted every start")


def _load(file: Path) -> trimesh.Trimesh | None:
    try:
        with np.load(file) as data:
            arrays = {key: data[key] for key in data.files}
    except (OSError, ValueError):
        return None  # absent or damaged: converted again and rewritten
    return trimesh.Trimesh(process=False, **arrays)


@functools.lru_cache(maxsize=256)
def _mesh_file(path: str) -> trimesh.Trimesh:
    file = _cache_file(path)
    mesh = _load(file)
    if mesh is None:
        mesh = _convert(path)
        _save(mesh, file)
    return mesh


def _convert(path: str) -> trimesh.Trimesh:
    """Decode a mesh file; texture colours baked into vertex colours."""
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
    return decimate(mesh)


def decimate(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """`mesh` with DECIMATE_KEEP of its faces (at least DECIMATE_FLOOR), its colours carried to
    each kept vertex from the nearest original vertex."""
    target = max(DECIMATE_FLOOR, int(len(mesh.faces) * DECIMATE_KEEP))
    if len(mesh.faces) <= target:
        return mesh
    simple = mesh.simplify_quadric_decimation(face_count=target)
    if isinstance(mesh.visual, trimesh.visual.ColorVisuals) and mesh.visual.kind is not None:
        colours = mesh.visual.vertex_colors  # face colours are spread to vertices
        nearest = cKDTree(mesh.vertices).query(simple.vertices)[1]
        simple.visual = trimesh.visual.ColorVisuals(simple, vertex_colors=colours[nearest])
    return simple


def visual_mesh(visual: Visual) -> trimesh.Trimesh | None:
    """The mesh of one URDF visual in its own frame, coloured; None for a mesh format not read."""
    if visual.shape == "box":
        mesh = trimesh.creation.box(extents=np.asarray(visual.size))
    elif visual.shape == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=visual.size[0])
    elif visual.shape == "cylinder":
        mesh = trimesh.creation.cylinder(radius=visual.size[0], height=visual.size[1])
    elif visual.mesh is not None and visual.mesh.suffix.lower() in (".dae", ".stl", ".obj"):
        mesh = _mesh_file(str(visual.mesh)).copy()
        mesh.apply_scale(np.asarray(visual.size))
        if visual.rgba is None and visual.mesh.suffix.lower() == ".dae":
            return mesh
    else:
        return None
    rgba = np.clip(np.asarray(visual.rgba or DEFAULT_RGBA) * 255.0, 0, 255).astype(np.uint8)
    mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=np.tile(rgba, (len(mesh.faces), 1)))
    return mesh
