"""The robot drawn in viser from its URDF visual meshes, posed from `lab/state` messages.

The sim process sends the world placement of every link (and contact frame) in each state
message; each visual mesh is a child scene node of its link's frame at its fixed URDF origin, so
one state update moves one node per link. No kinematics run here.
"""

from collections.abc import Callable, Mapping

import numpy as np
import viser
import viser.transforms as vtf

from lab.description import RobotDescription
from lab.ui.meshes import visual_mesh
from lab.urdf_visuals import read_visuals

DragCallback = Callable[[viser.SceneNodeDragEvent, str], None]


class RobotView:
    """Scene nodes of one robot under `root` (e.g. "/robot").

    `on_drag(event, link_name)` is called for drags on any visual mesh, with the name of the URDF
    link the mesh belongs to.
    """

    def __init__(
        self,
        server: viser.ViserServer,
        desc: RobotDescription,
        root: str = "/robot",
        on_drag: DragCallback | None = None,
    ) -> None:
        self.name = desc.name
        self._server = server
        self._links: dict[str, viser.FrameHandle] = {}
        self._meshes: list[viser.MeshHandle] = []
        self._placements: dict[str, vtf.SE3] = {}
        for k, visual in enumerate(read_visuals(desc.urdf_path, desc.package_dirs)):
            if visual.link not in self._links:
                node = f"{root}/l{len(self._links)}"
                self._links[visual.link] = server.scene.add_frame(node, show_axes=False)
            mesh = visual_mesh(visual)
            if mesh is None:
                continue
            parent = self._links[visual.link].name
            handle = server.scene.add_mesh_trimesh(
                f"{parent}/v{k}",
                mesh,
                position=visual.origin[:3, 3],
                wxyz=vtf.SO3.from_matrix(visual.origin[:3, :3]).wxyz,
            )
            if on_drag is not None:

                def forward(event: viser.SceneNodeDragEvent, link: str = visual.link) -> None:
                    on_drag(event, link)

                handle.on_drag(forward)
            self._meshes.append(handle)

    def set_state(self, frames: Mapping[str, list]) -> None:
        """Pose the robot from a `lab/state` message's `frames` (names, positions, quaternions
        x y z w, world)."""
        placements = {
            name: vtf.SE3.from_rotation_and_translation(
                vtf.SO3(np.array([w, x, y, z])), np.asarray(position)
            )
            for name, position, (x, y, z, w) in zip(
                frames["names"], frames["positions"], frames["quaternions"], strict=True
            )
        }
        self._placements = placements
        with self._server.atomic():
            for link, node in self._links.items():
                placement = placements.get(link)
                if placement is not None:
                    node.position = placement.translation()
                    node.wxyz = placement.rotation().wxyz

    @property
    def drawn(self) -> bool:
        """Whether a state of this robot has posed it (placements exist only from then on)."""
        return bool(self._placements)

    def frame_placement(self, frame: str) -> vtf.SE3:
        """World placement of a link or contact frame at the last drawn state."""
        if frame not in self._placements:
            raise KeyError(f"robot {self.name!r} has no frame {frame!r}")
        return self._placements[frame]

    def remove(self) -> None:
        for node in self._links.values():
            node.remove()
