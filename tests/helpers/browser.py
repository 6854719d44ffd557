"""Helpers for the browser tests: a `lab serve` process with its UI on free loopback ports, and
Debian's headless Chromium driven by playwright (never a downloaded browser)."""

import shutil
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from lab.client import LabClient
from tests.helpers.ports import free_port

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
STARTUP_TIMEOUT_S = 60.0
# Never SCHED_FIFO for the server under test: a FIFO 1 kHz loop can starve the UI process and
# Chromium on a 2-core machine (later LabServe args override this).
SERVE_OPTIONS = ("--sched", "other")


def serves_http(port: int) -> bool:
    """Whether an HTTP server answers a GET on `port` of the loopback. (A bare TCP connection
    closed unanswered makes viser's websocket server print a handshake traceback, which the
    browser tests count as a fault.)"""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2.0):
            return True
    except OSError:
        return False


class LabServe:
    """`lab serve` (sim process + UI process) on free ports, output to `log`."""

    def __init__(self, log: Path, *args: str, port: int | None = None) -> None:
        self.port = free_port() if port is None else port
        self.ui_port = free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.url = f"http://127.0.0.1:{self.ui_port}"
        self.log = log
        cmd = [sys.executable, "-m", "lab.runtime.serve", "--port", str(self.port)]
        cmd += ["--ui-port", str(self.ui_port), *SERVE_OPTIONS, *args]
        with log.open("wb") as out:
            self.process = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)

    def output(self) -> str:
        return self.log.read_text(errors="replace")[-4000:]

    def client(self) -> LabClient:
        end = time.monotonic() + STARTUP_TIMEOUT_S
        while time.monotonic() < end:
            assert self.process.poll() is None, f"lab serve exited:\n{self.output()}"
            try:
                client = LabClient(self.endpoint, connect_timeout=1.0)
            except Exception:  # not listening yet
                time.sleep(0.3)
                continue
            if client.command("info").get("ok"):
                return client
            client.close()
            time.sleep(0.3)
        raise TimeoutError(
            f"lab serve did not answer within {STARTUP_TIMEOUT_S} s:\n{self.output()}"
        )

    def wait_ui(self) -> None:
        """Wait until the UI process serves HTTP."""
        end = time.monotonic() + STARTUP_TIMEOUT_S
        while time.monotonic() < end:
            assert self.process.poll() is None, f"lab serve exited:\n{self.output()}"
            if serves_http(self.ui_port):
                return
            time.sleep(0.3)
        raise TimeoutError(f"the UI did not serve HTTP within {STARTUP_TIMEOUT_S} s")

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(10.0)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
