"""The current scene's floor and terrain, drawn from the same geometry the sim builds its world
from (`lab.scenes`), so what is drawn is what is simulated. A moving body (a platform, a tilting
board) is a frame whose geoms are its children: `set_poses` puts it where the sim's `lab/state`
says it is."""

import numpy as np
import viser

from lab.scenes import scene_bodies, scene_geoms
from lab.scenes.geometry import TerrainGeom

TERRAIN_COLOUR = (176, 168, 150)


class TerrainView:
    def __init__(self, server: viser.ViserServer, scene: str, root: str = "/terrain") -> None:
        self._nodes: list[viser.SceneNodeHandle] = []
        for k, g in enumerate(scene_geoms(scene)):
            self._nodes.append(_add_geom(server, f"{root}/g{k}", g))
        self._bodies: dict[str, viser.FrameHandle] = {}
        for body in scene_bodies(scene):
            frame = server.scene.add_frame(
                f"{root}/{body.name}", show_axes=False, position=np.array(body.position)
            )
            self._bodies[body.name] = frame
            for k, g in enumerate(body.geoms):
                self._nodes.append(_add_geom(server, f"{root}/{body.name}/g{k}", g))
            self._nodes.append(frame)

    def set_poses(self, poses: dict[str, list[float]]) -> None:
        """Pose the moving bodies: name -> [x, y, z, qw, qx, qy, qz] (a `lab/state`'s
        `scene_bodies`); names this scene does not have are ignored (a scene switch in flight)."""
        for name, pose in poses.items():
            frame = self._bodies.get(name)
            if frame is not None and len(pose) == 7:
                frame.position = np.array(pose[:3])
                frame.wxyz = np.array(pose[3:])

    def remove(self) -> None:
        for node in self._nodes:
            node.remove()


def _add_geom(server: viser.ViserServer, name: str, g: TerrainGeom) -> viser.SceneNodeHandle:
    """One terrain geom as a viser node `name` (placed in its parent node's frame)."""
    s = server.scene
    pos, wxyz, size = np.array(g.position), np.array(g.wxyz), g.size
    if g.shape == "plane":
        extent = 2.0 * np.array(size[:2]) if size[0] > 0 else np.array([40.0, 40.0])
        return s.add_grid(
            name,
            float(extent[0]),
            float(extent[1]),
            cell_size=0.25,
            section_size=1.0,
            plane_color=(235, 235, 230),
            plane_opacity=1.0,
            position=pos,
            wxyz=wxyz,
        )
    if g.shape == "box":
        dimensions = tuple(2.0 * np.array(size))
        return s.add_box(name, TERRAIN_COLOUR, dimensions=dimensions, position=pos, wxyz=wxyz)
    if g.shape == "cylinder":
        return s.add_cylinder(
            name,
            float(size[0]),
            float(2.0 * size[1]),
            color=TERRAIN_COLOUR,
            position=pos,
            wxyz=wxyz,
        )
    return s.add_icosphere(name, float(size[0]), color=TERRAIN_COLOUR, position=pos, wxyz=wxyz)
