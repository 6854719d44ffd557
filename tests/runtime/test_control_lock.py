"""The control lock (docs/protocol.md, "The control lock"): its bookkeeping, then through real
Zenoh against a live loop: with no holder every client commands as before; a holder's commands
pass, another client's world-changing ones are refused naming the holder while it reads freely;
the lock goes on `release` and when the holder's link drops."""

from lab.client import LabClient
from lab.runtime.control_lock import GRACE_S, ControlLock
from tests.helpers.processes import WAIT_S, live_server, wait_for


def test_the_lock_refuses_others_and_goes_after_its_holders_link_drops() -> None:
    lock = ControlLock()
    assert lock.refusal("b", "pause") is None  # no holder: as without a lock
    assert "no liveliness token" in lock.take("a")
    lock.seen("a", True, 0.0)
    lock.seen("b", True, 0.0)
    assert lock.take("a") is None and lock.take("a") is None  # taking it again is fine
    assert "client a holds" in lock.take("b")
    assert "pause: client a holds the control lock" in lock.refusal("b", "pause")
    assert lock.refusal("b", "info") is None and lock.refusal("a", "pause") is None
    assert "does not hold" in lock.release("b")
    lock.seen("a", False, 10.0)
    assert lock.expire(10.0 + GRACE_S / 2) is None and lock.holder == "a"
    lock.seen("a", True, 10.0 + GRACE_S / 2)  # back within the grace: kept
    lock.seen("a", False, 20.0)
    assert lock.expire(20.0 + GRACE_S) == "a" and lock.holder is None
    assert lock.take("b") is None and lock.release("b") is None and lock.holder is None


def test_the_lock_through_zenoh() -> None:
    with live_server("solo12") as server:
        a = server.client
        with LabClient(server.endpoint) as b:
            assert b.command("pause")["ok"] and b.command("resume")["ok"]  # no holder
            taken = a.command("take")
            a_id = taken["control"]["holder"]
            assert taken["ok"] and a_id == a.client_id
            # telemetry and `info` say who holds it (the page greys its controls by them)
            assert b.command("info")["control"] == {"holder": a_id}
            b.wait_telemetry(lambda m: m["control"] == {"holder": a_id}, timeout=WAIT_S)
            refused = b.command("pause")
            assert not refused["ok"] and a_id in refused["error"], refused
            assert refused["error"].startswith("pause:")
            assert not b.command("velocity", vx=0.3)["ok"]
            assert b.command("info")["ok"]  # read-only: always
            assert a_id in b.command("take")["error"]
            assert a.command("pause")["ok"] and a.command("resume")["ok"]
            assert a.command("release") == {"ok": True, "control": {"holder": None}}
            b.wait_telemetry(lambda m: m["control"] == {"holder": None}, timeout=WAIT_S)
            assert b.command("pause")["ok"] and b.command("resume")["ok"]
            assert b.command("take")["ok"]

        # b's link dropped (closed): after the deadman's grace another client may take it
        def a_takes() -> bool:
            return a.command("take")["ok"]

        wait_for(a_takes, WAIT_S, "the lock released after its holder's link dropped")
        # a role names the kind of client in the lock's refusals
        with LabClient(server.endpoint, role="teleop") as teleop:
            assert teleop.client_id.startswith("teleop-")
            refused = teleop.command("pause")
            assert not refused["ok"] and f"client {a.client_id} holds" in refused["error"]
            assert f"this client ({teleop.client_id})" in refused["error"]
        assert a.command("release")["ok"]
