"""The README's screenshot (docs/screenshot.png): `lab serve` with ANYmal trotting forward, the
page in Debian's headless Chromium (software-rendered), taken once the plots have filled.

    python docs/figures/screenshot.py [--out docs/screenshot.png] [--seconds 25]

Take it on a quiet machine: the status line shows the loop's on-time fraction against the
machine's floor, and a busy machine shows its warnings instead.
"""

import argparse
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from playwright.sync_api import sync_playwright

from lab.client import LabClient

ROOT = Path(__file__).resolve().parent.parent.parent
VIEWPORT = {"width": 1600, "height": 900}
CHROMIUM_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]
STARTUP_S = 60.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(predicate, what: str) -> None:
    end = time.monotonic() + STARTUP_S
    while not predicate():
        if time.monotonic() > end:
            raise TimeoutError(f"{what} did not come up within {STARTUP_S:g} s")
        time.sleep(0.3)


def serves_http(port: int) -> bool:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2.0):
            return True
    except OSError:
        return False


def connect(endpoint: str) -> LabClient | None:
    try:
        client = LabClient(endpoint, connect_timeout=1.0)
    except Exception:  # not listening yet
        return None
    if client.command("info").get("ok"):
        return client
    client.close()
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "screenshot.png")
    parser.add_argument("--seconds", type=float, default=25.0, help="trotting before the shot")
    args = parser.parse_args()
    port, ui_port = free_port(), free_port()
    log = Path(tempfile.mkdtemp(prefix="lab-screenshot-")) / "serve.log"
    with log.open("wb") as out:
        serve = subprocess.Popen(
            [sys.executable, "-m", "lab", "serve", "--port", str(port), "--ui-port", str(ui_port)],
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    client: LabClient | None = None
    try:
        end = time.monotonic() + STARTUP_S
        while (client := connect(f"tcp/127.0.0.1:{port}")) is None:
            if time.monotonic() > end or serve.poll() is not None:
                raise TimeoutError(f"lab serve did not answer (its log: {log})")
            time.sleep(0.3)
        wait_for(lambda: serves_http(ui_port), "the page")
        with sync_playwright() as p:
            browser = p.chromium.launch(
                executable_path=shutil.which("chromium") or "/usr/bin/chromium",
                headless=True,
                args=CHROMIUM_ARGS,
            )
            page = browser.new_page(viewport=VIEWPORT)
            page.goto(f"http://127.0.0.1:{ui_port}/")
            assert client.command("gait", name="trot")["ok"]
            assert client.command("velocity", vx=0.3)["ok"]
            end = time.monotonic() + args.seconds
            while time.monotonic() < end:  # the velocity deadman wants a fresh command
                client.command("velocity", vx=0.3)
                page.wait_for_timeout(200)
            # viser's toast that WebGL is software-rendered (headless Chromium has no GPU)
            # would cover the 3D view: close it.
            for close in page.locator(".mantine-Notification-closeButton").all():
                close.click()
            page.wait_for_timeout(500)
            page.screenshot(path=str(args.out))
            browser.close()
        print(f"wrote {args.out} (lab serve's log: {log})")
        return 0
    finally:
        if client is not None:
            client.close()
        serve.terminate()
        serve.wait(10.0)


if __name__ == "__main__":
    sys.exit(main())
