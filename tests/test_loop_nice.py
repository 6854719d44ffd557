"""The loop's nice value: asked for at SCHED_OTHER, kept with the slice, not passed on to the
threads it starts, refused cleanly without the privilege."""

import os
import threading
from collections.abc import Callable
from typing import TypeVar

import pytest

import lab.server.loop as loop_module
from lab.server.loop import LoopConfig, SimLoop, request_fifo, request_nice, request_slice

T = TypeVar("T")


def _in_a_thread(function: Callable[[], T]) -> T:
    """Run `function` in a new thread (scheduling calls change the calling thread only)."""
    result = []
    thread = threading.Thread(target=lambda: result.append(function()))
    thread.start()
    thread.join()
    return result[0]


def _nice() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def test_a_granted_nice_holds_with_the_slice_and_is_not_inherited() -> None:
    """The nice value the loop is granted stays when the slice is asked for after it; a thread
    the loop starts runs at nice 0. Raising the priority needs CAP_SYS_NICE: without it the
    request reports None and leaves the thread as it was."""

    def ask() -> tuple[int, int | None, float | None, int, int]:
        before = _nice()
        granted = request_nice(-5)
        sliced = request_slice(2e-4)
        return before, granted, sliced, _nice(), _in_a_thread(_nice)

    main_before = _nice()
    before, granted, sliced, after, child = _in_a_thread(ask)
    if granted is None:
        assert after == before  # refused: nothing changed
        pytest.skip("a raised priority is refused here (no CAP_SYS_NICE)")
    assert granted == -5 and after == -5  # the slice request kept it
    assert sliced is None or sliced == pytest.approx(2e-4)
    assert child == 0
    assert _nice() == main_before  # only the asking thread changed
    assert _in_a_thread(lambda: request_nice(3)) == 3  # lowering it needs no privilege


def test_a_refused_or_fifo_nice_request_reports_none(monkeypatch: pytest.MonkeyPatch) -> None:
    """A refused sched_setattr gives None and changes nothing; so does a SCHED_FIFO thread,
    whose nice the request must not touch."""
    monkeypatch.setattr(loop_module, "_SYS_SCHED_SETATTR", {})
    before = _in_a_thread(_nice)
    assert _in_a_thread(lambda: (request_nice(4), _nice())) == (None, before)
    monkeypatch.undo()
    fifo, granted = _in_a_thread(lambda: (request_fifo(), request_nice(-5)))
    if not fifo:
        pytest.skip("SCHED_FIFO refused on this machine (no privileges)")
    assert granted is None


class _Stopping:
    """A session that stops the loop after a few ticks."""

    def __init__(self, stop: threading.Event) -> None:
        self.stop, self.ticks = stop, 0

    def tick(self) -> None:
        self.ticks += 1
        if self.ticks == 5:
            self.stop.set()

    def handle(self, verb: str, payload: object) -> dict:
        return {"ok": True}

    def telemetry(self) -> dict:
        return {"t": 0.0}

    def drawing_state(self) -> dict:
        return {}

    def pop_events(self) -> list[dict]:
        return []


class _Dropping:
    def receive(self) -> None:
        return None

    def reply(self, request: object, body: dict) -> None: ...
    def publish_telemetry(self, message: dict) -> None: ...
    def publish_state(self, message: dict) -> None: ...
    def publish_event(self, message: dict) -> None: ...


@pytest.mark.parametrize("nice", [7, None])
def test_the_loop_reports_the_nice_it_was_granted(nice: int | None) -> None:
    """A realtime loop at SCHED_OTHER asks for `nice` and reports what it was granted (a nice
    above 0 needs no privilege); with None it asks for nothing and reports None."""
    stop = threading.Event()
    loop = SimLoop(_Stopping(stop), _Dropping(), LoopConfig(rate_hz=2000, sched="other", nice=nice))
    thread = threading.Thread(target=loop.run, args=(stop,))
    thread.start()
    thread.join()
    assert loop.error is None
    assert loop.stats.snapshot()["nice"] == nice


@pytest.mark.parametrize(
    ("argv", "named"),
    [(["--nice", "-30"], "--nice"), (["--spin-ms", "1.5"], "--spin-ms")],
)
def test_serve_refuses_an_out_of_range_loop_setting_by_name(
    argv: list[str], named: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`lab serve` names the loop setting that is out of range and starts nothing (a spin of
    the whole period, 1 ms at 1 kHz, is allowed; longer is not)."""
    from lab.server.serve import serve_main

    assert serve_main(argv) == 2
    assert named in capsys.readouterr().err
