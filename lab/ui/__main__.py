"""`python -m lab.ui --port <http> --connect <zenoh endpoint>`: the browser lab process."""

import argparse
import signal
import threading

from lab.protocol import DEFAULT_ENDPOINT
from lab.ui.app import LabApp


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m lab.ui", description=__doc__)
    parser.add_argument("--port", type=int, default=8080, help="HTTP port (default: 8080)")
    parser.add_argument("--host", default="127.0.0.1", help="HTTP bind address (default: loopback)")
    parser.add_argument("--connect", default=DEFAULT_ENDPOINT, help="Zenoh endpoint of the server")
    args = parser.parse_args(argv)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    app = LabApp(args.port, args.connect, host=args.host)
    print(f"lab ui: http://{args.host}:{args.port} (Zenoh {args.connect})", flush=True)
    try:
        app.run(stop)
    finally:
        app.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
