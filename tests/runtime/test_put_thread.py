"""The publisher thread of the sim process's transport: order, errors, back-pressure, close."""

import threading
import time

import pytest

from lab.runtime.transport import PUBLISH_BACKLOG, PutThread


class _Publisher:
    """Records what is put on it, from which thread; `block` holds the putting thread."""

    def __init__(self, name: str, fail_on: bytes | None = None) -> None:
        self.name, self.fail_on = name, fail_on
        self.block = threading.Event()
        self.block.set()

    def put(self, payload: bytes) -> None:
        self.block.wait()
        if payload == self.fail_on:
            raise RuntimeError(f"{self.name}: refused {payload!r}")
        _PUT.append((self.name, payload, threading.current_thread().name))


_PUT: list[tuple[str, bytes, str]] = []


@pytest.fixture(autouse=True)
def _clear() -> None:
    _PUT.clear()


def test_puts_leave_in_order_from_their_own_thread_and_close_drains_them() -> None:
    telemetry, state = _Publisher("telemetry"), _Publisher("state")
    puts = PutThread()
    sent = [(telemetry if i % 3 else state, str(i).encode()) for i in range(50)]
    for publisher, payload in sent:
        puts.put(publisher, payload)
    puts.close()
    assert [(name, payload) for name, payload, _ in _PUT] == [(p.name, b) for p, b in sent]
    assert {thread for _, _, thread in _PUT} == {"zenoh-put"}


def test_a_failed_put_is_raised_on_the_next_put() -> None:
    publisher = _Publisher("events", fail_on=b"bad")
    puts = PutThread()
    puts.put(publisher, b"bad")
    puts.put(publisher, b"after")  # may still find the thread busy with "bad"
    puts.close()
    with pytest.raises(RuntimeError, match="refused b'bad'"):
        puts.put(publisher, b"next")
    assert [payload for _, payload, _ in _PUT] == [b"after"]


def test_a_starved_thread_leaves_the_puts_to_the_caller() -> None:
    """With PUBLISH_BACKLOG messages waiting, the caller puts itself: nothing piles up."""
    publisher = _Publisher("telemetry")
    publisher.block.clear()  # the thread takes the first message and hangs in its put
    puts = PutThread()
    puts.put(publisher, b"first")
    end = time.monotonic() + 10.0
    while puts._queue.qsize() and time.monotonic() < end:  # until the thread holds "first"
        time.sleep(0.001)
    for i in range(PUBLISH_BACKLOG):
        puts.put(publisher, str(i).encode())
    publisher.block.set()  # the caller's own put below must not wait for the thread
    puts.put(publisher, b"inline")
    puts.close()
    caller = threading.current_thread().name
    assert [payload for _, payload, thread in _PUT if thread == caller] == [b"inline"]
    assert len(_PUT) == PUBLISH_BACKLOG + 2
