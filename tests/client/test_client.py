"""LabClient failure paths: nothing listening, a server that never answers, reply decoding."""

import json
import socket
import threading
import time

import pytest
import zenoh

from lab.client import LabClient
from lab.protocol import MAX_PAYLOAD_BYTES, LabKeys, PushCommand
from lab.runtime.intake import ANONYMOUS, BURST, CLIENT_QUEUE
from lab.runtime.transport import MAX_MESSAGE_BYTES, ServerTransport, server_config

LAB = "client-decoding"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_connecting_to_nothing_fails_within_the_timeout() -> None:
    start = time.monotonic()
    with pytest.raises(zenoh.ZError):
        LabClient(f"tcp/127.0.0.1:{free_port()}", connect_timeout=0.3)
    assert time.monotonic() - start < 2.0


def test_unanswered_command_becomes_an_error_reply_and_telemetry_wait_times_out() -> None:
    port = free_port()
    transport = ServerTransport(server_config(port), "client-unanswered")  # nobody drains queries
    try:
        with LabClient(f"tcp/127.0.0.1:{port}") as lab:
            start = time.monotonic()
            reply = lab.command("info", timeout=0.3)
            assert reply == {"ok": False, "error": "info: no reply within 0.3 s"}
            assert 0.25 < time.monotonic() - start < 2.0
            assert lab.latest_telemetry() is None
            with pytest.raises(TimeoutError):
                lab.wait_telemetry(timeout=0.2)
            transport.publish_telemetry({"t": 1.5})
            sent = {"t": 1.5, "control": {"holder": None}}  # the transport adds the lock's holder
            assert lab.wait_telemetry(lambda m: m["t"] == 1.5, timeout=2.0) == sent
            assert lab.latest_telemetry() == sent
    finally:
        transport.close()


def test_queries_are_validated_off_the_loop_and_answered_on_their_key() -> None:
    """A valid command reaches `receive` typed, with the client's id; a bad one is answered by
    the intake thread itself, naming what was wrong, and never reaches `receive`."""
    port = free_port()
    transport = ServerTransport(server_config(port), LAB)
    try:
        with LabClient(f"tcp/127.0.0.1:{port}") as lab:
            session = lab.session
            push = b'{"body": "base", "force": [0, 10, 0], "duration": 0.1}'
            replies = lab_query(session, LAB, "push", push, attachment="tester-1")
            request = _receive(transport)
            assert (request.verb, request.payload["body"], request.client) == (
                "push",
                "base",
                "tester-1",
            )
            assert isinstance(request.command, PushCommand) and request.command.force[1] == 10.0
            transport.reply(request, {"ok": True, "echo": request.payload})
            reply = next(iter(replies))
            assert str(reply.ok.key_expr) == "lab/client-decoding/cmd/push"
            assert json.loads(reply.ok.payload.to_bytes())["echo"]["body"] == "base"
            refused = [
                (b"null", "got null"),
                (b"[1,", "not valid JSON"),
                (b'{"vx": 9}', "'vx'"),
                (b"1" * (MAX_PAYLOAD_BYTES + 1), f"{MAX_PAYLOAD_BYTES}-byte cap"),
            ]
            for payload, error in refused:
                answer = json.loads(
                    next(iter(lab_query(session, LAB, "velocity", payload))).ok.payload.to_bytes()
                )
                assert answer["ok"] is False and error in answer["error"], answer
                assert answer["error"].startswith("velocity:")
            bad_id = lab_query(session, LAB, "info", b"{}", attachment="not an id!")
            assert "client id" in json.loads(next(iter(bad_id)).ok.payload.to_bytes())["error"]
            assert transport.receive() is None
            assert transport.rejections()[0] == len(refused) + 1
            lab_query(session, LAB, "reset", b"", attachment=None)  # no attachment: anonymous
            request = _receive(transport)
            assert (request.verb, request.payload, request.client) == ("reset", {}, ANONYMOUS)
            transport.reply(request, {"ok": True})
    finally:
        transport.close()


def test_a_message_over_zenohs_cap_is_dropped_before_the_lab_reads_it() -> None:
    """Up to MAX_MESSAGE_BYTES an oversized payload is refused with the protocol's cap; beyond,
    Zenoh drops it unanswered (the sim process never holds it), and the link still serves."""
    port = free_port()
    transport = ServerTransport(server_config(port), LAB)
    try:
        with LabClient(f"tcp/127.0.0.1:{port}") as lab:
            session = lab.session
            near = b" " * (MAX_MESSAGE_BYTES - 1024)  # fragmented (over 64 KiB), under the cap
            answer = json.loads(
                next(iter(lab_query(session, LAB, "velocity", near))).ok.payload.to_bytes()
            )
            assert f"{MAX_PAYLOAD_BYTES}-byte cap" in answer["error"]
            read = transport._intake.payload_bytes
            huge = b" " * (8 * MAX_MESSAGE_BYTES)
            dropped = lab_query(session, LAB, "velocity", huge, timeout=0.5)
            assert [r for r in dropped if r.ok is not None] == []  # no reply: a timeout
            assert transport._intake.payload_bytes == read  # never reached the intake
            answer = json.loads(
                next(iter(lab_query(session, LAB, "velocity", b"null"))).ok.payload.to_bytes()
            )
            assert "got null" in answer["error"]  # the same link still answers
    finally:
        transport.close()


def test_a_client_over_its_rate_or_queue_is_told_so() -> None:
    port = free_port()
    transport = ServerTransport(server_config(port), LAB)  # nobody drains: commands wait
    try:
        with LabClient(f"tcp/127.0.0.1:{port}") as lab:
            session = lab.session
            sent = [
                lab_query(session, LAB, "pause", b"{}", attachment="flood")
                for _ in range(BURST * 2)
            ]
            answers = [json.loads(r.ok.payload.to_bytes()) for h in sent[CLIENT_QUEUE:] for r in h]
            errors = [a["error"] for a in answers]
            assert any("rate limit" in e and "flood" in e for e in errors), errors[-3:]
            assert any(f"busy: {CLIENT_QUEUE} commands" in e for e in errors), errors[:3]
            taken = [_receive(transport) for _ in range(CLIENT_QUEUE)]
            assert {r.client for r in taken} == {"flood"} and transport.receive() is None
            for request in taken:
                transport.reply(request, {"ok": True})
    finally:
        transport.close()


def lab_query(
    session: zenoh.Session,
    lab: str,
    verb: str,
    payload: bytes,
    attachment: str | None = "tester",
    timeout: float = 2.0,
) -> zenoh.Handler:
    """A raw query to `lab/<lab>/cmd/<verb>`, with `attachment` as the client id."""
    key = f"lab/{lab}/cmd/{verb}"
    return session.get(key, payload=payload, timeout=timeout, attachment=attachment)


def _receive(transport: ServerTransport):
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        if (request := transport.receive()) is not None:
            return request
        time.sleep(0.001)
    raise TimeoutError("no query arrived")


def test_a_query_dropped_unanswered_says_so_not_that_it_timed_out() -> None:
    """A lab whose command queue is full drops the oldest query (a ring channel): its querier
    hears at once that it was closed unanswered, not 'no reply within 2 s' after 0.1 s."""
    port = free_port()
    server = zenoh.open(server_config(port))
    keys = LabKeys("client-dropped")
    queue = server.declare_queryable(keys.cmd("**"), zenoh.handlers.RingChannel(1))  # unread
    try:
        with LabClient(f"tcp/127.0.0.1:{port}", lab_id=keys.lab_id) as lab:
            replies: list[dict] = []
            first = threading.Thread(target=lambda: replies.append(lab.command("info", timeout=20)))
            start = time.monotonic()
            first.start()
            time.sleep(0.3)  # the first waits in the queue
            second = lab.command("reset", timeout=0.5)  # takes its place: the first is dropped
            first.join(20)
            (reply,) = replies
            assert time.monotonic() - start < 10  # not the 20 s of its timeout
            assert reply["error"].startswith("info: the query was closed unanswered after ")
            assert "its queue of waiting commands was full" in reply["error"]
            assert second == {"ok": False, "error": "reset: no reply within 0.5 s"}
    finally:
        queue.undeclare()
        server.close()
