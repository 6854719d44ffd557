"""`lab router`: a Zenoh session in router mode (zenohd's core, shipped in eclipse-zenoh), where
sim processes (`lab serve --connect ENDPOINT`) and clients (the UI, `lab teleop`, `LabClient`)
meet when they run on different hosts. A user's own `zenohd` does the same job. SIGINT/SIGTERM
stop it; the links through it break, and come back when a router listens again."""

import argparse
import signal
import sys

import zenoh

from lab.protocol import DEFAULT_PORT
from lab.runtime.transport import AccessError, checked_server_config


def router_main(argv: list[str]) -> int:
    """`lab router [--port P | --listen ENDPOINT ...] [--users FILE] [--zenoh-config FILE]`."""
    parser = argparse.ArgumentParser(prog="lab router", description=__doc__)
    parser.add_argument("--port", type=int, default=DEFAULT_PORT, help="TCP port on 127.0.0.1")
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="listen on this Zenoh endpoint instead of 127.0.0.1 (e.g. tcp/0.0.0.0:7447)",
    )
    parser.add_argument("--users", metavar="FILE", help="admit only these user:password lines")
    parser.add_argument("--zenoh-config", metavar="FILE", help="a Zenoh configuration to extend")
    parser.add_argument(
        "--open",
        action="store_true",
        help="allow a non-loopback --listen with neither --users nor authentication or TLS in "
        "--zenoh-config",
    )
    args = parser.parse_args(argv)
    try:
        config, access, _ = checked_server_config(
            "lab router", args.port, args.listen, users_file=args.users,
            base_file=args.zenoh_config, opened=args.open, mode="router",
        )  # fmt: skip
    except AccessError as error:
        print(error, file=sys.stderr)
        return 2
    stop = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, stop)  # taken by sigwait below, on this thread
    try:
        session = zenoh.open(config)
    except zenoh.ZError as error:  # a port in use, a configuration it cannot use
        print(f"lab router: Zenoh: {error}", file=sys.stderr)
        return 2
    print(f"lab router: listening on {access.describe()}", flush=True)
    try:
        signal.sigwait(stop)
    finally:
        session.close()
    return 0
