"""`python -m lab.ui --port <http> --connect <zenoh endpoint> [--lab-id ID]`: the browser lab
process."""

import argparse
import os
import signal
import sys
import threading

import zenoh

from lab.protocol import DEFAULT_ENDPOINT, LabIdError, LabKeys
from lab.ui.app import LabApp
from lab.ui.render_loop import RenderLoop

PARENT_CHECK_S = 1.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m lab.ui", description=__doc__)
    parser.add_argument("--port", type=int, default=8080, help="HTTP port (default: 8080)")
    parser.add_argument("--host", default="127.0.0.1", help="HTTP bind address (default: loopback)")
    parser.add_argument("--connect", default=DEFAULT_ENDPOINT, help="Zenoh endpoint of the server")
    parser.add_argument(
        "--lab-id",
        help="the lab to show first (default: the first one seen; the page lists every lab)",
    )
    parser.add_argument(
        "--exit-with-parent",
        action="store_true",
        help="stop when the process that started this one dies (lab serve passes it)",
    )
    args = parser.parse_args(argv)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    if args.exit_with_parent:
        threading.Thread(target=_watch_parent, args=(stop,), daemon=True).start()
    try:
        if args.lab_id is not None:
            LabKeys(args.lab_id)  # checked before the HTTP server starts
    except LabIdError as error:
        print(f"lab ui: --lab-id: {error}", file=sys.stderr, flush=True)
        return 2
    try:
        app = LabApp(args.port, args.connect, host=args.host, stop=stop, lab_id=args.lab_id)
    except zenoh.ZError as error:
        print(f"lab ui: no lab server at {args.connect}: {error}", file=sys.stderr, flush=True)
        return 1
    print(f"lab ui: http://{args.host}:{args.port} (Zenoh {args.connect})", flush=True)
    try:
        RenderLoop(app).run(stop)
    finally:
        app.close()
    return 0


def _watch_parent(stop: threading.Event) -> None:
    """Set `stop` once the parent is gone (a `lab serve` killed by SIGKILL runs no cleanup: its
    UI would otherwise serve a page of a dead sim, holding its port)."""
    parent = os.getppid()
    while not stop.wait(PARENT_CHECK_S):
        if os.getppid() != parent:
            print("lab ui: lab serve is gone; stopping", flush=True)
            stop.set()


if __name__ == "__main__":
    raise SystemExit(main())
