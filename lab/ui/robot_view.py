"""The robot drawn in viser from its URDF visual meshes, posed from `lab/state` messages.

Pinocchio computes the forward kinematics of the joint frames; each visual mesh is a child scene
node of its joint frame with the fixed URDF placement, so one state update moves one node per
joint.
"""

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pinocchio as pin
import viser

from lab.description import RobotDescription, add_frames
from lab.ui.meshes import geometry_mesh

DragCallback = Callable[[viser.SceneNodeDragEvent, str], None]


def _wxyz(rotation: np.ndarray) -> np.ndarray:
    x, y, z, w = pin.Quaternion(rotation).coeffs()
    return np.array([w, x, y, z])


class RobotView:
    """Scene nodes of one robot under `root` (e.g. "/robot").

    The model is the full URDF (locked joints included, drawn at the SRDF reference posture) with
    the description's added contact frames, so every frame the sim's model names (a Talos sole
    centre, an ANYmal foot centre) has a placement here too.
    `on_drag(event, link_name)` is called for drags on any visual mesh, with the name of the URDF
    link (pinocchio frame) the mesh belongs to.
    """

    def __init__(
        self,
        server: viser.ViserServer,
        desc: RobotDescription,
        root: str = "/robot",
        on_drag: DragCallback | None = None,
    ) -> None:
        urdf = str(desc.urdf_path)
        self.model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
        self.visual = pin.buildGeomFromUrdf(
            self.model,
            urdf,
            pin.GeometryType.VISUAL,
            package_dirs=[str(p) for p in desc.package_dirs],
        )
        add_frames(self.model, desc)  # after the geometry: frames added to the model only
        self.data = self.model.createData()
        self.q = pin.neutral(self.model)
        # joints the server does not report (locked ones) keep the reference posture
        pin.loadReferenceConfigurations(self.model, str(desc.srdf_path), False)
        if desc.posture in self.model.referenceConfigurations:
            self.q = np.array(self.model.referenceConfigurations[desc.posture])
        self._server = server
        self._root = root
        self._joint_q_index = {
            self.model.names[j]: self.model.joints[j].idx_q
            for j in range(2, self.model.njoints)
            if self.model.joints[j].nq == 1
        }
        self._frames = [
            server.scene.add_frame(f"{root}/j{j}", show_axes=False)
            for j in range(self.model.njoints)
        ]
        self._meshes = []
        for k, geom in enumerate(self.visual.geometryObjects):
            mesh = geometry_mesh(geom)
            if mesh is None:
                continue
            handle = server.scene.add_mesh_trimesh(
                f"{root}/j{geom.parentJoint}/g{k}",
                mesh,
                position=geom.placement.translation,
                wxyz=_wxyz(geom.placement.rotation),
            )
            if on_drag is not None:
                link = self.model.frames[geom.parentFrame].name

                def forward(event: viser.SceneNodeDragEvent, link: str = link) -> None:
                    on_drag(event, link)

                handle.on_drag(forward)
            self._meshes.append(handle)

    @property
    def root_link(self) -> str:
        """The URDF root link (the floating base)."""
        return next(
            f.name for f in self.model.frames if f.type == pin.FrameType.BODY and f.parentJoint == 1
        )

    @property
    def joint_names(self) -> list[str]:
        return list(self._joint_q_index)

    def set_state(
        self,
        base_position: Sequence[float],
        base_quat_xyzw: Sequence[float],
        joints: Mapping[str, float],
    ) -> None:
        """Pose the robot; joints missing from `joints` keep their last value."""
        q = self.q
        q[:3] = base_position
        quat = np.asarray(base_quat_xyzw, dtype=float)
        q[3:7] = quat / np.linalg.norm(quat)
        for name, value in joints.items():
            idx = self._joint_q_index.get(name)
            if idx is not None:
                q[idx] = value
        pin.forwardKinematics(self.model, self.data, q)
        with self._server.atomic():
            for j in range(1, self.model.njoints):
                placement = self.data.oMi[j]
                frame = self._frames[j]
                frame.position = placement.translation
                frame.wxyz = _wxyz(placement.rotation)

    def frame_placement(self, frame: str) -> pin.SE3:
        """World placement of a URDF or added contact frame at the last drawn state."""
        if not self.model.existFrame(frame):
            raise KeyError(f"robot {self.model.name!r} has no frame {frame!r}")
        fid = self.model.getFrameId(frame)
        return pin.updateFramePlacement(self.model, self.data, fid)

    def remove(self) -> None:
        for frame in self._frames:
            frame.remove()
