"""Real `lab serve` / `lab router` processes for the tests, and waiting on them (from
tests/runtime/test_faults.py)."""

import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from lab.client import LabClient
from lab.runtime.loop import LoopConfig, SimLoop
from lab.runtime.transport import ServerTransport, server_config
from lab.world.session import Session, SessionConfig
from tests.helpers.ports import free_port

RATE_HZ = 250.0
STARTUP_S = 90.0  # a server or UI process importing MuJoCo, pinocchio, viser on a busy machine
WAIT_S = 30.0  # for something that takes a fraction of a second on an idle machine


def wait_for(condition: Callable[[], object], timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise TimeoutError(f"{what}: not within {timeout:g} s")
        time.sleep(0.05)


# ------------------------------------------------------------------ faults inside the sim
class FaultySession(Session):
    """A session that runs injected faults on the loop thread, just before a tick."""

    def __init__(self, config: SessionConfig) -> None:
        super().__init__(config)
        self._injected: list[tuple[int, Callable[[Session], None]]] = []
        self._calls = 0
        self._lock = threading.Lock()

    def inject(self, fault: Callable[[Session], None], ticks_later: int = 0) -> None:
        """Run `fault(session)` before the next tick, or `ticks_later` ticks after that."""
        with self._lock:
            self._injected.append((self._calls + ticks_later, fault))

    def tick(self) -> None:
        with self._lock:
            due = [fault for at, fault in self._injected if at <= self._calls]
            self._injected = [(at, fault) for at, fault in self._injected if at > self._calls]
            self._calls += 1
        for fault in due:
            fault(self)
        super().tick()


class LiveServer:
    """A session in a real loop thread behind a real Zenoh transport, and a client with every
    event it received."""

    def __init__(self, robot: str) -> None:
        self.session = FaultySession(SessionConfig(robot=robot))
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.transport = ServerTransport(server_config(listen=[self.endpoint]), "faults")
        self.loop = SimLoop(
            self.session, self.transport, LoopConfig(rate_hz=RATE_HZ, sched="other")
        )
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.loop.run, args=(self.stop,))
        self.thread.start()
        self.events: list[dict] = []
        try:  # a server that does not come up must not leave its loop thread running
            self.client = LabClient(self.endpoint)
        except BaseException:
            self._stop_loop()
            raise
        try:
            self.client.subscribe_events(self.events.append)
            self.client.wait_telemetry(timeout=WAIT_S)
            # A refused command's event back: the server has the subscription (the command
            # follows it on the client's one link), so no injected fault's event is published
            # before the client listens.
            assert not self.client.command("velocity", vx=99.0)["ok"]
            self.event("rejected_command")
        except BaseException:
            self.client.close()
            self._stop_loop()
            raise

    def event(self, kind: str) -> dict:
        wait_for(lambda: any(e["type"] == kind for e in self.events), WAIT_S, f"a {kind} event")
        return next(e for e in self.events if e["type"] == kind)

    def telemetry_after(self, t: float) -> dict:
        """The first telemetry of sim time later than `t`."""
        return self.client.wait_telemetry(lambda m: m["t"] > t, timeout=WAIT_S)

    def close(self) -> None:
        self.client.close()
        self._stop_loop()
        assert self.loop.error is None, repr(self.loop.error)

    def _stop_loop(self) -> None:
        self.stop.set()
        self.thread.join()
        self.transport.close()


@contextmanager
def live_server(robot: str = "anymal") -> Iterator[LiveServer]:
    server = LiveServer(robot)
    try:
        yield server
    finally:
        server.close()


# ------------------------------------------------------------------ faults around the sim
class Process:
    """A child process with its output in a log file; killed at the end if still running."""

    def __init__(self, log: Path, *args: str) -> None:
        self.log = log
        with open(log, "ab") as out:
            self.process = subprocess.Popen(
                [sys.executable, *args], stdout=out, stderr=subprocess.STDOUT
            )

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()


def serve(log: Path, port: int, *args: str) -> Process:
    """`lab serve` on loopback `port` at RATE_HZ."""
    return Process(
        log,
        *("-m", "lab.runtime.serve", "--port", str(port), "--rate", str(RATE_HZ)),
        *("--sched", "other", *args),
    )


@contextmanager
def processes() -> Iterator[list[Process]]:
    started: list[Process] = []
    try:
        yield started
    finally:
        for process in started:
            process.kill()


def ready_client(endpoint: str, server: Process) -> LabClient:
    """A client once the server answers `info` (the server may still be importing)."""
    end = time.monotonic() + STARTUP_S
    while True:
        assert server.process.poll() is None, server.output()
        try:
            client = LabClient(endpoint, connect_timeout=1.0)
        except Exception:
            assert time.monotonic() < end, server.output()
            time.sleep(0.5)
            continue
        if client.wait_connected(timeout=STARTUP_S) and client.command("info", timeout=5.0)["ok"]:
            client.wait_telemetry(timeout=WAIT_S)
            return client
        client.close()
        assert time.monotonic() < end, server.output()


@contextmanager
def headless_server(tmp_path: Path) -> Iterator[tuple[list[Process], LabClient, str]]:
    """A headless `lab serve`, a ready client and the endpoint; the list gathers processes to
    kill at the end."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    with processes() as running:
        server = serve(tmp_path / "serve.log", port, "--headless")
        running.append(server)
        with ready_client(endpoint, server) as lab:
            yield running, lab, endpoint
