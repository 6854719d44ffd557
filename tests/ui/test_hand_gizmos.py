"""The page's hand gizmos (lab/ui/hand_gizmos.py) against an in-process session: one per hand at
its target, shown while the `hands` task is in the stack, and a moved gizmo sets the target."""

import numpy as np

from lab.ui.hand_gizmos import HandGizmos
from lab.world.session import Session, SessionConfig
from tests.helpers.hands import HAND_STACK
from tests.helpers.ui import _SessionHost, viser_server  # noqa: F401 (a fixture)


def test_a_moved_gizmo_sends_its_pose_as_the_hands_target(viser_server) -> None:  # noqa: F811
    import viser.transforms as tf

    session = Session(SessionConfig(robot="talos_arms"))
    host = _SessionHost(session)
    gizmos = HandGizmos(host, viser_server)  # the server's scene stands in for a client's
    gizmos.show_ownership(True)
    gizmos.show_info(session.info())
    assert sorted(gizmos.handles) == ["left", "right"]
    left = gizmos.handles["left"]
    np.testing.assert_allclose(left.position, session.info()["hands"][0]["position"], atol=1e-6)
    assert not left.visible  # talos_arms' default stack has no hands task
    assert session.handle("stack", {"levels": HAND_STACK})["ok"]
    gizmos.show_info(session.info())
    assert left.visible
    goal, rpy = (0.25, 0.4, 0.9), (0.1, -0.3, 0.2)
    left.position, left.wxyz = goal, tf.SO3.from_rpy_radians(*rpy).wxyz
    gizmos._moved("left", left)  # what a drag's update calls
    assert host.sent[-1][0] == "hand"
    target = session.info()["hands"][0]
    np.testing.assert_allclose(target["position"], goal, atol=1e-6)
    np.testing.assert_allclose(target["rpy"], rpy, atol=1e-6)
    sent = len(host.sent)
    elsewhere = [0.3, 0.35, 0.95]  # another client (a scenario, teleop) sets the target
    assert session.handle("hand", {"name": "left", "position": elsewhere})["ok"]
    gizmos.show_info(session.info())
    np.testing.assert_allclose(left.position, elsewhere, atol=1e-6)
    assert len(host.sent) == sent  # following it sends nothing back
    gizmos.show_ownership(False)
    assert not left.visible  # only the browser in control drags


def test_a_robot_without_hands_gets_no_gizmo(viser_server) -> None:  # noqa: F811
    session = Session(SessionConfig(robot="anymal"))
    gizmos = HandGizmos(_SessionHost(session), viser_server)
    gizmos.show_info(session.info())
    assert gizmos.handles == {}
