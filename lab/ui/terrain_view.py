"""The current scene's floor and terrain, read from the same scene builders MuJoCo uses.

`lab.scenes` adds static geoms to an `MjSpec`; building one empty spec per scene and reading its
geoms back keeps the drawing and the simulated world identical without duplicating the terrain.
"""

import mujoco
import numpy as np
import viser

from lab.scenes import add_scene

TERRAIN_COLOUR = (176, 168, 150)


class TerrainView:
    def __init__(
        self, server: viser.ViserServer, scene: str, friction: float, root: str = "/terrain"
    ) -> None:
        spec = mujoco.MjSpec()
        add_scene(spec, scene, friction)
        s = server.scene
        self._nodes: list[viser.SceneNodeHandle] = []
        for k, g in enumerate(spec.worldbody.geoms):
            name, pos, wxyz = f"{root}/g{k}", np.array(g.pos), np.array(g.quat)  # MuJoCo: w x y z
            size = np.array(g.size)
            if g.type == mujoco.mjtGeom.mjGEOM_PLANE:
                extent = 2.0 * size[:2] if size[0] > 0 else np.array([40.0, 40.0])
                node = s.add_grid(
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
            elif g.type == mujoco.mjtGeom.mjGEOM_BOX:
                node = s.add_box(
                    name, TERRAIN_COLOUR, dimensions=tuple(2.0 * size), position=pos, wxyz=wxyz
                )
            elif g.type == mujoco.mjtGeom.mjGEOM_CYLINDER:
                node = s.add_cylinder(
                    name,
                    float(size[0]),
                    float(2.0 * size[1]),
                    color=TERRAIN_COLOUR,
                    position=pos,
                    wxyz=wxyz,
                )
            elif g.type == mujoco.mjtGeom.mjGEOM_SPHERE:
                node = s.add_icosphere(
                    name, float(size[0]), color=TERRAIN_COLOUR, position=pos, wxyz=wxyz
                )
            else:
                continue
            self._nodes.append(node)

    def remove(self) -> None:
        for node in self._nodes:
            node.remove()
