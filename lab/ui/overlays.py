"""Toggleable 3-D overlays drawn from telemetry: contact forces, friction cones, support polygon,
CoM ground projection, centres of pressure, applied pushes and the drag-push spring."""

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import trimesh
import viser

from lab.protocol import ContactSpec
from lab.ui.colors import friction_usage, usage_colour
from lab.ui.support import sole_corners, support_polygon

FORCE_SCALE = 1.0 / 400.0  # m of arrow per N
PUSH_SCALE = 1.0 / 200.0
CONE_HEIGHT = 0.12  # m
GROUND_NORMAL = np.array([0.0, 0.0, 1.0])
LIFT = np.array([0.0, 0.0, 0.003])  # m above the ground, so flat marks are not z-fighting
OVERLAYS = (
    "contact forces",
    "friction cones",
    "support polygon",
    "CoM projection",
    "CoP",
    "pushes",
)

# world rotation of a contact frame, by frame name, at the drawn state
FrameRotation = Callable[[str], np.ndarray]


@dataclass
class _Nodes:
    forces: viser.ArrowsHandle | None = None
    cones: list[viser.MeshHandle] | None = None
    polygon: viser.LineSegmentsHandle | None = None
    com: viser.IcosphereHandle | None = None
    com_line: viser.LineSegmentsHandle | None = None
    cop_net: viser.IcosphereHandle | None = None
    cop_feet: viser.PointCloudHandle | None = None
    pushes: viser.ArrowsHandle | None = None


def _segments_loop(vertices: np.ndarray) -> np.ndarray:
    if len(vertices) < 2:
        return np.zeros((0, 2, 3))
    return np.stack([vertices, np.roll(vertices, -1, axis=0)], axis=1)


def _cone_mesh(mu: float) -> trimesh.Trimesh:
    """Friction cone, apex at the origin, opening along +z up to CONE_HEIGHT."""
    cone = trimesh.creation.cone(radius=mu * CONE_HEIGHT, height=CONE_HEIGHT, sections=24)
    cone.apply_transform(trimesh.transformations.rotation_matrix(np.pi, [1, 0, 0]))
    cone.apply_translation([0.0, 0.0, CONE_HEIGHT])
    return cone


class Overlays:
    def __init__(
        self,
        server: viser.ViserServer,
        contacts: Sequence[ContactSpec],
        mu: float,
        frame_rotation: FrameRotation,
        root: str = "/overlays",
    ) -> None:
        self._server = server
        self._contacts = {c.name: c for c in contacts}
        self._mu = mu
        self._frame_rotation = frame_rotation
        self._root = root
        self.visible = dict.fromkeys(OVERLAYS, True)
        self.visible["friction cones"] = False
        s = server.scene
        self._n = _Nodes()
        self._n.cones = [
            s.add_mesh_simple(
                f"{root}/cones/{c.name}",
                vertices=_cone_mesh(mu).vertices,
                faces=_cone_mesh(mu).faces,
                color=(90, 140, 230),
                opacity=0.35,
                visible=False,
            )
            for c in contacts
        ]
        self._n.com = s.add_icosphere(f"{root}/com", radius=0.02, color=(30, 30, 30))
        self._n.cop_net = s.add_icosphere(f"{root}/cop_net", radius=0.018, color=(220, 40, 200))
        self._drag = s.add_arrows(
            f"{root}/drag",
            np.zeros((1, 2, 3)),
            (250, 120, 0),
            shaft_radius=0.008,
            head_radius=0.02,
            head_length=0.04,
            visible=False,
        )

    def set_visible(self, overlay: str, visible: bool) -> None:
        if overlay not in self.visible:
            raise KeyError(f"unknown overlay {overlay!r}; known: {', '.join(OVERLAYS)}")
        self.visible[overlay] = visible

    def show_drag(self, grab: np.ndarray | None, pointer: np.ndarray | None) -> None:
        """The drag-push spring from the grab point to the pointer, or hide it (None)."""
        if grab is None or pointer is None:
            self._drag.visible = False
            return
        self._drag.points = np.array([[grab, pointer]], dtype=np.float32)
        self._drag.visible = True

    def _arrows(self, node: viser.ArrowsHandle | None, name: str, pts, colors, radius):
        if len(pts) == 0:
            if node is not None:
                node.visible = False
            return node
        pts = np.asarray(pts, dtype=np.float32)
        colors = np.asarray(colors, dtype=np.uint8)
        if node is None or node.points.shape != pts.shape:
            if node is not None:
                node.remove()
            return self._server.scene.add_arrows(
                name,
                pts,
                colors,
                shaft_radius=radius,
                head_radius=2.5 * radius,
                head_length=5 * radius,
            )
        node.points = pts
        node.colors = colors
        node.visible = True
        return node

    def _lines(self, node, name: str, segments: np.ndarray, colour, visible: bool):
        if not visible or len(segments) == 0:
            if node is not None:
                node.visible = False
            return node
        segments = np.asarray(segments, dtype=np.float32)
        if node is None or node.points.shape != segments.shape:
            if node is not None:
                node.remove()
            return self._server.scene.add_line_segments(name, segments, colour, thickness=0.006)
        node.points = segments
        node.visible = True
        return node

    def update(self, telemetry: dict) -> None:
        """Redraw every overlay from one telemetry message."""
        v = self.visible
        n = self._n
        contacts = [c for c in telemetry["contacts"] if c["active"]]
        positions = np.array([c["position"] for c in contacts]).reshape(-1, 3)
        with self._server.atomic():
            # contact forces: arrows from the contact point, coloured by friction usage
            force_pts, force_cols = [], []
            if v["contact forces"]:
                for c, p in zip(contacts, positions, strict=True):
                    f = np.asarray(c["measured_force"], dtype=float)
                    force_pts.append([p, p + FORCE_SCALE * f])
                    force_cols.append(usage_colour(friction_usage(f, GROUND_NORMAL, self._mu)))
            n.forces = self._arrows(n.forces, f"{self._root}/forces", force_pts, force_cols, 0.008)
            # friction cones at the active contacts
            active = {c["name"]: p for c, p in zip(contacts, positions, strict=True)}
            for spec, cone in zip(self._contacts.values(), n.cones or [], strict=True):
                cone.visible = v["friction cones"] and spec.name in active
                if cone.visible:
                    cone.position = active[spec.name]
            # support polygon: hull of point feet and of flat soles' corners
            ground = []
            for c, p in zip(contacts, positions, strict=True):
                spec = self._contacts.get(c["name"])
                if spec is not None and spec.kind == "flat":
                    rot = self._frame_rotation(spec.frame)
                    ground.extend(sole_corners(p, rot, spec.half_length, spec.half_width))
                else:
                    ground.append(p - GROUND_NORMAL * (spec.radius if spec else 0.0))
            polygon = support_polygon(np.array(ground).reshape(-1, 3)) + LIFT
            n.polygon = self._lines(
                n.polygon,
                f"{self._root}/polygon",
                _segments_loop(polygon),
                (20, 120, 240),
                v["support polygon"],
            )
            # CoM ground projection
            com = np.asarray(telemetry["com"]["position"], dtype=float)
            ground_z = float(polygon[:, 2].mean()) if len(polygon) else 0.0
            foot = np.array([com[0], com[1], ground_z])
            n.com.visible = v["CoM projection"]
            n.com.position = foot
            n.com_line = self._lines(
                n.com_line,
                f"{self._root}/com_line",
                np.array([[com, foot]]),
                (30, 30, 30),
                v["CoM projection"],
            )
            # centres of pressure
            net = telemetry["cop"]["net"]
            n.cop_net.visible = v["CoP"] and net is not None
            if net is not None:
                n.cop_net.position = np.asarray(net) + LIFT
            feet = [p for p in telemetry["cop"]["feet"].values() if p is not None]
            if v["CoP"] and feet:
                pts = (np.asarray(feet) + LIFT).astype(np.float32)
                if n.cop_feet is None or n.cop_feet.points.shape != pts.shape:
                    if n.cop_feet is not None:
                        n.cop_feet.remove()
                    n.cop_feet = self._server.scene.add_point_cloud(
                        f"{self._root}/cop_feet",
                        pts,
                        (240, 130, 230),
                        point_size=0.025,
                        point_shape="circle",
                    )
                n.cop_feet.points = pts
                n.cop_feet.visible = True
            elif n.cop_feet is not None:
                n.cop_feet.visible = False
            # pushes being applied: arrows ending at the application point
            push_pts = []
            if v["pushes"]:
                for push in telemetry["pushes"]:
                    point = np.asarray(push["point"], dtype=float)
                    force = np.asarray(push["force"], dtype=float)
                    push_pts.append([point - PUSH_SCALE * force, point])
            n.pushes = self._arrows(
                n.pushes, f"{self._root}/pushes", push_pts, [(240, 60, 30)] * len(push_pts), 0.012
            )

    def remove(self) -> None:
        for node in vars(self._n).values():
            for handle in node if isinstance(node, list) else [node]:
                if handle is not None:
                    handle.remove()
        self._drag.remove()
