"""The current scene's floor and terrain, drawn from the same geometry the sim builds its world
from (`lab.scenes`), so what is drawn is what is simulated."""

import numpy as np
import viser

from lab.scenes import scene_geoms

TERRAIN_COLOUR = (176, 168, 150)


class TerrainView:
    def __init__(self, server: viser.ViserServer, scene: str, root: str = "/terrain") -> None:
        s = server.scene
        self._nodes: list[viser.SceneNodeHandle] = []
        for k, g in enumerate(scene_geoms(scene)):
            name, pos, wxyz, size = f"{root}/g{k}", np.array(g.position), np.array(g.wxyz), g.size
            if g.shape == "plane":
                extent = 2.0 * np.array(size[:2]) if size[0] > 0 else np.array([40.0, 40.0])
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
            elif g.shape == "box":
                node = s.add_box(
                    name,
                    TERRAIN_COLOUR,
                    dimensions=tuple(2.0 * np.array(size)),
                    position=pos,
                    wxyz=wxyz,
                )
            elif g.shape == "cylinder":
                node = s.add_cylinder(
                    name,
                    float(size[0]),
                    float(2.0 * size[1]),
                    color=TERRAIN_COLOUR,
                    position=pos,
                    wxyz=wxyz,
                )
            else:  # sphere
                node = s.add_icosphere(
                    name, float(size[0]), color=TERRAIN_COLOUR, position=pos, wxyz=wxyz
                )
            self._nodes.append(node)

    def remove(self) -> None:
        for node in self._nodes:
            node.remove()
