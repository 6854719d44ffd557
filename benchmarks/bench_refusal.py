"""Where the intake's time per refused query goes (issue 25; not a test, not in CI).

A queryable like the sim process's (`server_config`, the same channel) flooded by
`--flooders` processes of benchmarks/bench_load.py's `flood` (64 KB `gains` commands, 32 in
flight each); this process reads `--queries` of them and answers each as the intake answers a
client over its rate, timing each call with `time.thread_time_ns` (CPU of this thread: what
holds the GIL, or waits in Rust with it released in `reply` and `drop`). No loop runs beside it.

    .venv/bin/python benchmarks/bench_refusal.py [--queries 4000] [--flooders 3]
"""

import argparse
import multiprocessing
import os
import socket
import sys
import time
from itertools import pairwise
from pathlib import Path

import zenoh

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from benchmarks.bench_load import flood
from lab.protocol import LabKeys
from lab.runtime.intake import client_of
from lab.runtime.transport import COMMAND_QUEUE, encode, server_config

STEPS = ("recv", "payload size", "key as str", "client_of", "encode reply", "reply", "drop")


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--queries", type=int, default=4000)
    parser.add_argument("--flooders", type=int, default=3)
    args = parser.parse_args()
    port, keys = free_port(), LabKeys("bench")
    session = zenoh.open(server_config(port))
    queryable = session.declare_queryable(keys.cmd("**"), zenoh.handlers.RingChannel(COMMAND_QUEUE))
    spawn = multiprocessing.get_context("spawn")
    stop, sent, replies = spawn.Event(), spawn.Value("q", 0), spawn.Value("q", 0)
    endpoint = f"tcp/127.0.0.1:{port}"
    flooders = [
        spawn.Process(target=flood, args=(endpoint, "bench", 64, stop, sent, replies))
        for _ in range(args.flooders)
    ]
    for process in flooders:
        process.start()
    time.sleep(3.0)  # they connected and flood
    spent = dict.fromkeys(STEPS, 0)
    clock = time.thread_time_ns
    for _ in range(args.queries):
        stamps = [clock()]
        query = queryable.recv()
        stamps.append(clock())
        len(query.payload)
        stamps.append(clock())
        verb = str(query.key_expr).removeprefix(keys.cmd_prefix)
        stamps.append(clock())
        client, _ = client_of(query)
        stamps.append(clock())
        error = f"{verb}: rate limit: client {client} sent more than 100 commands/s"
        body = encode({"ok": False, "error": error})
        stamps.append(clock())
        query.reply(query.key_expr, body, express=True)
        stamps.append(clock())
        query.drop()
        stamps.append(clock())
        for step, (begin, end) in zip(STEPS, pairwise(stamps), strict=True):
            spent[step] += end - begin
    stop.set()
    for process in flooders:
        process.join(10.0)
    session.close()
    for step, ns in spent.items():
        print(f"{step:14s} {ns / args.queries / 1e3:6.1f} µs of CPU per query")
    print(
        f"{'total':14s} {sum(spent.values()) / args.queries / 1e3:6.1f} µs; load {os.getloadavg()}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
