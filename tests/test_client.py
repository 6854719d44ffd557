"""LabClient failure paths: nothing listening, a server that never answers, reply decoding."""

import json
import socket
import threading
import time

import pytest
import zenoh

from lab.client import LabClient
from lab.protocol import LabKeys
from lab.server.transport import ServerTransport, server_config


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
            assert lab.wait_telemetry(lambda m: m["t"] == 1.5, timeout=2.0) == {"t": 1.5}
            assert lab.latest_telemetry() == {"t": 1.5}
    finally:
        transport.close()


def test_queries_are_decoded_and_answered_on_their_key() -> None:
    port = free_port()
    transport = ServerTransport(server_config(port), "client-decoding")
    try:
        with LabClient(f"tcp/127.0.0.1:{port}") as lab:
            session = lab._session
            push = b'{"body": "base"}'
            handler = session.get("lab/client-decoding/cmd/push", payload=push, timeout=2.0)
            request = _receive(transport)
            assert (request.verb, request.payload, request.error) == (
                "push",
                {"body": "base"},
                None,
            )
            transport.reply(request, {"ok": True, "echo": request.payload})
            reply = next(iter(handler))
            assert str(reply.ok.key_expr) == "lab/client-decoding/cmd/push"
            assert json.loads(reply.ok.payload.to_bytes()) == {"ok": True, "echo": {"body": "base"}}
            for payload, error in [(b"", None), (b"null", "got null"), (b"[1,", "not valid JSON")]:
                session.get("lab/client-decoding/cmd/reset", payload=payload, timeout=0.5)
                request = _receive(transport)
                assert request.error is None if error is None else error in request.error
                transport.reply(request, {"ok": error is None})
    finally:
        transport.close()


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
