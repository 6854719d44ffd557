"""Reproducer (not a test): the resident memory a bare Zenoh queryable takes under a flood of
64 KB queries, and whether it is given back, with no lab code in the serving process.

A peer session with one queryable (a ring channel, as the sim process has) and a thread that
answers each query at once; `--flooders` client processes send 64 KB queries with up to 32 in
flight each (benchmarks/bench_load.py's flooding client) for `--duration` s; then quiet for as
long. With `--trim`, glibc's malloc_trim(0) is called once after the flood. With `--lab` the
lab's own intake answers instead (`ServerTransport`: client ids, rate limits, size cap,
validation, the ring of COMMAND_QUEUE queries, MAX_MESSAGE_BYTES and the heap trimmer; nobody
takes the valid commands, and the flood sends none): the difference is the lab's part. Each
sample is the resident memory and glibc's heap (`heap_usage`: in use by live allocations, and
freed but kept by malloc). Run it with the environment the question needs (e.g.
MALLOC_ARENA_MAX=1) and compare:

    .venv/bin/python benchmarks/zenoh_flood_memory.py [--duration 10] [--trim]
"""

import argparse
import json
import multiprocessing
import sys
import threading
import time
from pathlib import Path

import zenoh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_load import flood, rss_mb

from lab.protocol import LabKeys
from lab.runtime.transport import COMMAND_QUEUE, ServerTransport, server_config
from lab.world.memory import heap_usage, release_free_memory

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.helpers.ports import free_port


def serve(queryable: zenoh.Queryable) -> None:
    """Answer every query at once until the session closes."""
    while True:
        try:
            query = queryable.recv()
        except zenoh.ZError:
            return
        query.reply(query.key_expr, b'{"ok": false, "error": "refused"}')
        query.drop()


def sample(pid: int) -> dict[str, object]:
    """The resident memory (MB) and glibc's heap now."""
    return {"rss": round(rss_mb(pid), 1), "heap": heap_usage()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--flooders", type=int, default=5)
    parser.add_argument("--flood-kb", type=int, default=64)
    parser.add_argument("--trim", action="store_true", help="malloc_trim(0) after the flood")
    parser.add_argument("--lab", action="store_true", help="the lab's intake answers")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=JSON",
        help="a Zenoh configuration setting of the serving session, e.g. "
        "transport/shared_memory/enabled=false",
    )
    args = parser.parse_args()
    port = free_port()
    config = server_config(port)
    for setting in args.set:
        key, value = setting.split("=", 1)
        config.insert_json5(key, value)
    keys = LabKeys("flood")
    if args.lab:
        transport = ServerTransport(config, keys.lab_id)
        close = transport.close
    else:
        session = zenoh.open(config)
        queryable = session.declare_queryable(
            keys.cmd("**"), zenoh.handlers.RingChannel(COMMAND_QUEUE)
        )
        thread = threading.Thread(target=serve, args=(queryable,))
        thread.start()

        def close() -> None:
            session.close()
            thread.join()

    pid = multiprocessing.current_process().pid
    report: dict[str, object] = {"lab": args.lab, "set": args.set}
    report["before"] = sample(pid)
    spawn = multiprocessing.get_context("spawn")
    stop, replies = spawn.Event(), spawn.Value("l", 0)
    endpoint = f"tcp/127.0.0.1:{port}"
    flooders = [
        spawn.Process(target=flood, args=(endpoint, keys.lab_id, args.flood_kb, stop, replies))
        for _ in range(args.flooders)
    ]
    for process in flooders:
        process.start()
    samples = []
    end = time.monotonic() + args.duration
    while time.monotonic() < end:
        time.sleep(1.0)
        samples.append(sample(pid))
    stop.set()
    for process in flooders:
        process.join(30.0)
    report["flood"] = samples
    report["replies"] = replies.value
    time.sleep(1.0)  # the last queries answered
    report["flood_ended"] = sample(pid)
    if args.trim:
        report["trimmed"] = release_free_memory()
    time.sleep(args.duration)
    report["after"] = sample(pid)
    close()
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
