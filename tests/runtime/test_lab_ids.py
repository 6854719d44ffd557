"""Lab ids: every key of a lab under `lab/<id>/`, and clients that list the labs behind a router,
choose one, switch, and see one go offline and come back (no sim: bare transports, fast)."""

import time
from concurrent.futures import ThreadPoolExecutor

import pytest
import zenoh

from lab.client import LabClient, LabNotFound
from lab.client_core import find_labs, open_session
from lab.directory import LabDirectory, next_online
from lab.protocol import LabIdError, LabKeys, default_lab_id, lab_id_of
from lab.runtime.transport import ServerTransport, server_config
from lab.teleop import TeleopState, labs_line, status_line
from lab.ui.lab_picker import lab_label, lab_of, labs_note
from lab.ui.link import Link
from tests.helpers.ports import free_port

WAIT_S = 10.0  # for what takes milliseconds on an idle machine


def wait_for(condition, what: str, publish=lambda: None) -> None:
    """Until `condition()`; `publish()` before each look (a subscriber just declared may miss
    a message sent before the router knows it)."""
    end = time.monotonic() + WAIT_S
    while not (publish(), condition())[1]:
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.02)


def test_every_key_of_a_lab_is_scoped_by_its_id() -> None:
    keys = LabKeys("hostA-anymal")
    assert keys.cmd("push") == "lab/hostA-anymal/cmd/push"
    assert (keys.telemetry, keys.state, keys.events, keys.alive) == (
        "lab/hostA-anymal/telemetry",
        "lab/hostA-anymal/state",
        "lab/hostA-anymal/events",
        "lab/hostA-anymal/alive",
    )
    assert lab_id_of(keys.alive) == lab_id_of(keys.cmd("info")) == "hostA-anymal"
    assert lab_id_of("lab/alive") is None and lab_id_of("other/x/alive") is None
    for bad in ("", "a/b", "a*", "$x", "a b", "x" * 65):
        with pytest.raises(LabIdError, match="lab id"):
            LabKeys(bad)


def test_the_default_id_is_host_and_robot_made_a_key_chunk() -> None:
    assert default_lab_id("talos", host="rig-3.local") == "rig-3.local-talos"
    assert default_lab_id("anymal", host="my host/2*") == "my-host-2--anymal"
    LabKeys(default_lab_id("anymal"))  # this machine's name makes a valid id


def test_directory_marks_a_vanished_lab_offline_and_back() -> None:
    directory = LabDirectory()
    assert directory.seen("lab/b/alive", True) and directory.seen("lab/a/alive", True)
    assert not directory.seen("lab/a/alive", True)  # no change
    assert not directory.seen("unrelated/key", True)
    assert directory.seen("lab/a/alive", False)
    assert directory.labs() == {"a": False, "b": True}
    assert directory.next_online("b") == "b" and directory.next_online(None) == "b"
    directory.seen("lab/a/alive", True)
    assert directory.online() == ["a", "b"]
    assert next_online(directory.labs(), "a") == "b" and next_online(directory.labs(), "b") == "a"
    assert next_online({"a": False}, None) is None


def test_pickers_mark_offline_labs() -> None:
    assert lab_of(lab_label("a", False)) == "a" and lab_label("a", False) == "a (offline)"
    assert labs_note({"a": True, "b": False}) == "1 of 2 labs online; offline: b"
    line = labs_line({"a": True, "b": False}, "a")
    assert line == "labs: *a, b (offline)"
    assert status_line(None, TeleopState(), "b", online=False).startswith("[b OFFLINE] ")


class TwoLabs:
    """A Zenoh router on loopback and two bare lab transports joined to it (as `lab serve
    --connect` joins them), listening on their own loopback ports."""

    def __init__(self) -> None:
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.router = zenoh.open(server_config(listen=[self.endpoint], mode="router"))
        self.labs = {
            name: ServerTransport(server_config(free_port(), connect=[self.endpoint]), name)
            for name in ("ids-alpha", "ids-beta")
        }
        # both tokens at the router before a test looks: on a busy machine one lab's join can
        # lag the other's, and a client would then see one lab and take it
        session = open_session(self.endpoint, WAIT_S)
        try:
            wait_for(lambda: len(find_labs(session, WAIT_S)) == 2, "both labs at the router")
        finally:
            session.close()

    def close(self) -> None:
        for transport in self.labs.values():
            transport.close()
        self.router.close()


@pytest.fixture
def two_labs():
    labs = TwoLabs()
    try:
        yield labs
    finally:
        labs.close()


def _answer(transport: ServerTransport, reply: dict) -> str:
    """Answer the next command `transport` receives; its verb."""
    end = time.monotonic() + WAIT_S
    while (request := transport.receive()) is None:
        assert time.monotonic() < end, "no command arrived"
        time.sleep(0.005)
    transport.reply(request, reply)
    return request.verb


def test_a_client_behind_a_router_lists_chooses_and_switches_labs(two_labs) -> None:
    with pytest.raises(LabNotFound, match=r"2 labs .*ids-alpha, ids-beta"):
        LabClient(two_labs.endpoint)
    alpha, beta = two_labs.labs["ids-alpha"], two_labs.labs["ids-beta"]
    with LabClient(two_labs.endpoint, lab_id="ids-beta") as lab:
        wait_for(lambda: lab.labs() == {"ids-alpha": True, "ids-beta": True}, "both labs")
        assert lab.wait_connected()
        events: list[dict] = []
        lab.subscribe_events(events.append)
        last: list[dict] = []

        def publish_both() -> None:
            alpha.publish_telemetry({"t": 1.0, "lab": "alpha"})
            beta.publish_telemetry({"t": 2.0, "lab": "beta"})
            last.append(lab.latest_telemetry())

        wait_for(lambda: last[-1] is not None, "beta's telemetry", publish_both)
        assert all(m is None or m["lab"] == "beta" for m in last)
        # a command reaches beta only: alpha's queue stays empty
        with ThreadPoolExecutor(max_workers=1) as pool:
            reply = pool.submit(lambda: lab.command("pause", timeout=WAIT_S))
            assert _answer(beta, {"ok": True}) == "pause"
            assert reply.result(WAIT_S) == {"ok": True} and alpha.receive() is None

        lab.select("ids-alpha")  # callbacks follow the switch
        reset = {"type": "reset", "t": 0.0, "message": "alpha"}
        wait_for(lambda: events, "alpha's event", lambda: alpha.publish_event(reset))
        assert events[-1]["message"] == "alpha"
        wait_for(
            lambda: (lab.latest_telemetry() or {}).get("lab") == "alpha", "alpha", publish_both
        )

        two_labs.labs.pop("ids-alpha").close()  # alpha's sim process stops
        assert lab.wait_connected(False, WAIT_S)
        assert lab.labs() == {"ids-alpha": False, "ids-beta": True}
        back = ServerTransport(server_config(free_port(), connect=[two_labs.endpoint]), "ids-alpha")
        two_labs.labs["ids-alpha"] = back
        assert lab.wait_connected(True, WAIT_S)  # and returns
        assert lab.labs() == {"ids-alpha": True, "ids-beta": True}


def test_the_ui_link_watches_the_first_lab_and_switches(two_labs) -> None:
    link = Link(two_labs.endpoint)
    try:
        wait_for(lambda: (link.poll_labs(), link.lab_id)[1] is not None, "a lab to watch")
        assert link.lab_id in two_labs.labs  # the first seen
        wait_for(lambda: (link.poll_labs(), len(link.directory.labs()) == 2)[1], "both labs")
        link.select("ids-beta")
        received: list[dict] = []

        def publish_both() -> None:
            two_labs.labs["ids-beta"].publish_telemetry({"t": 5.0})
            two_labs.labs["ids-alpha"].publish_telemetry({"t": 6.0})
            received.extend(link.telemetry())

        wait_for(lambda: received, "beta's telemetry", publish_both)
        assert {m["t"] for m in received} == {5.0}
        two_labs.labs.pop("ids-beta").close()
        wait_for(lambda: not link.poll_connected(), "beta offline")
        assert link.directory.labs() == {"ids-alpha": True, "ids-beta": False}
    finally:
        link.close()
