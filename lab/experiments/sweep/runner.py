"""Running a sweep's points as Ray tasks, one scenario per task, results streamed to the table.

By default the command starts a local Ray instance with one worker per core (or `workers`) and
stops it at the end; with `address` it joins an existing cluster (`ray start --head` on one
host, `ray start --address HEAD:6379` on the others) and only disconnects. No more tasks are
in flight than there are workers, so a task runs soon after it is submitted: a point that has
not returned `timeout` seconds after its submission is cancelled (its worker killed) and becomes
an error row, as does a point whose scenario raised or whose worker died. Ctrl-C cancels the
tasks in flight and keeps the rows already written.
"""

import logging
import os
import socket
import sys
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import ray
from tqdm import tqdm

from lab.experiments.sweep.spec import Point, Sweep, check_scenario
from lab.experiments.sweep.table import ERROR, KEY, read_rows, result_row, write_rows

OBJECT_STORE_BYTES = 100 * 2**20  # results are small dicts; Ray's floor is 75 MiB
WAIT_S = 1.0  # how often the loop looks at timeouts while nothing finishes
CONNECT_TIMEOUT_S = 5.0  # to reach a cluster's HOST:PORT, and for its answer, before Ray joins
# HTTP/2's client connection preface and an empty SETTINGS frame (RFC 9113 §3.4, §6.5): a gRPC
# server such as Ray's GCS answers with a frame header (9 bytes) of type SETTINGS (4).
HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])
HTTP2_FRAME_HEADER = 9
HTTP2_SETTINGS = 4


@dataclass
class SweepOutcome:
    """What a `run_sweep` call did: points run (ok and failed), skipped as already in the
    table, whether Ctrl-C stopped it, its wall time and the part of it Ray took to start (s)."""

    ok: int = 0
    failed: int = 0
    skipped: int = 0
    interrupted: bool = False
    wall_s: float = 0.0
    ray_start_s: float = 0.0


def run_point(scenario: dict, base: str) -> dict:
    """Run one point's scenario in this process (a Ray task): `{"report": ...}` or
    `{"error": ...}`. Any exception is the point's failure, reported, never the sweep's."""
    from lab.experiments.scenario import run_scenario

    try:
        return {"report": run_scenario(check_scenario(scenario, Path(base)))}
    except Exception as error:
        return {"error": f"{type(error).__name__}: {error}"}


def run_sweep(
    sweep: Sweep,
    output: str | Path,
    workers: int | None = None,
    address: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    connect_timeout: float = CONNECT_TIMEOUT_S,
) -> SweepOutcome:
    """Run the points of `sweep` not yet in the table `output` and add their rows to it;
    `connect_timeout`: s to reach the cluster at `address` and for its answer."""
    start = time.monotonic()
    rows = read_rows(output)
    if retry_failed:
        rows = [row for row in rows if not row[ERROR]]
    done = {row[KEY] for row in rows}
    if sweep.series:  # a bisecting sweep: rounds of each series' next run, until all are done
        todo = sweep.next_points(rows)
        outcome = SweepOutcome(skipped=len(rows))
    else:
        todo = [point for point in sweep.points if point.key not in done]
        outcome = SweepOutcome(skipped=len(sweep.points) - len(todo))
    if todo:
        ours = not ray.is_initialized()  # a caller's own Ray session is used and left running
        if ours:
            _start_ray(workers, address, connect_timeout)
            outcome.ray_start_s = time.monotonic() - start
        try:
            slots = workers or int(ray.cluster_resources().get("CPU", 1))
            while todo and not outcome.interrupted:
                _stream(sweep, todo, rows, Path(output), slots, outcome, progress)
                todo = sweep.next_points(rows) if sweep.series else []
        finally:
            if ours:
                ray.shutdown()
    outcome.wall_s = time.monotonic() - start
    return outcome


class RayUnavailable(RuntimeError):
    """Ray did not start, or the cluster at `--address` could not be joined."""


def _start_ray(
    workers: int | None, address: str | None, connect_timeout: float = CONNECT_TIMEOUT_S
) -> None:
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # no usage report leaves the machine
    try:
        _init_ray(workers, address, connect_timeout)
    except (ConnectionError, ValueError, ray.exceptions.RayError) as error:
        where = f"the Ray cluster at {address}" if address else "a local Ray instance"
        raise RayUnavailable(f"{where}: {str(error).splitlines()[0]}") from error


def _check_ray(address: str, timeout: float = CONNECT_TIMEOUT_S) -> None:
    """Fail at once when nothing answers at a HOST:PORT `address`, or something that does not
    answer as Ray's GCS does (`ray.init` would retry for minutes: over 200 s, not stopped by
    Ctrl-C). The GCS is a gRPC server: it answers HTTP/2's connection preface with a SETTINGS
    frame. Other forms (`auto`, `ray://…`) and TLS clusters (RAY_USE_TLS) are left to Ray."""
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit() or "/" in address or os.environ.get("RAY_USE_TLS"):
        return
    try:
        connection = socket.create_connection((host.strip("[]"), int(port)), timeout)
    except OSError as error:
        message = f"nothing answers there ({error}): is `ray start --head` running?"
        raise ConnectionError(message) from error
    reply = b""
    with connection:
        try:
            connection.sendall(HTTP2_PREFACE)
            while len(reply) < HTTP2_FRAME_HEADER and (more := connection.recv(16)):
                reply += more
        except OSError:  # a timeout, or the connection closed on us
            pass
    if len(reply) < HTTP2_FRAME_HEADER or reply[3] != HTTP2_SETTINGS:
        got = f"it sent {reply[:16]!r}" if reply else f"no answer within {timeout:g} s"
        raise ConnectionError(
            f"something listens there but not as a Ray cluster does ({got} to a gRPC greeting): "
            "give the port of `ray start --head` (6379 by default)"
        )


def _init_ray(workers: int | None, address: str | None, connect_timeout: float) -> None:
    quiet = {"log_to_driver": False, "logging_level": logging.WARNING}
    if address:
        _check_ray(address, connect_timeout)
        ray.init(address=address, **quiet)
    else:
        ray.init(
            address="local",  # a new instance, never a cluster a `ray start` left recorded
            num_cpus=workers or os.cpu_count(),
            include_dashboard=False,
            object_store_memory=OBJECT_STORE_BYTES,
            # the node's address; Ray 2.60's GCS and raylet still bind every interface, behind
            # its token authentication (docs/sweeps.md)
            _node_ip_address="127.0.0.1",
            **quiet,
        )


def _stream(
    sweep: Sweep,
    todo: list[Point],
    rows: list[dict],
    output: Path,
    slots: int,
    outcome: SweepOutcome,
    progress: bool,
) -> None:
    """Keep `slots` tasks in flight, write each result as it comes, until done or Ctrl-C."""
    task = ray.remote(num_cpus=1, max_retries=0)(run_point)
    order = {point.key: i for i, point in enumerate(sweep.points)}
    pending = deque(todo)
    running: dict[object, tuple[Point, float]] = {}
    bar = tqdm(total=len(todo), unit="point", file=sys.stderr, disable=not progress)

    def record(point: Point, result: dict) -> None:
        error = result.get("error", "")
        rows.append(result_row(point.key, point.fields, result.get("report"), error))
        rows.sort(key=lambda row: order.get(row[KEY], len(order)))
        write_rows(output, rows)
        outcome.failed += bool(error)
        outcome.ok += not error
        bar.update()
        bar.set_postfix_str(f"ok {outcome.ok}, failed {outcome.failed}")

    try:
        while pending or running:
            while pending and len(running) < slots:
                point = pending.popleft()
                base = str(point.base or sweep.base)
                running[task.remote(point.scenario, base)] = (point, time.monotonic())
            ready, _ = ray.wait(list(running), num_returns=1, timeout=WAIT_S)
            for ref in ready:
                point, _ = running.pop(ref)
                try:
                    result = ray.get(ref)
                except ray.exceptions.RayError as error:  # the worker died, or Ray failed it
                    result = {"error": f"{type(error).__name__}: {str(error).splitlines()[0]}"}
                record(point, result)
            now = time.monotonic()
            for ref, (point, submitted) in list(running.items()):
                if now - submitted > sweep.timeout:
                    ray.cancel(ref, force=True)
                    del running[ref]
                    record(point, {"error": f"timeout: no result {sweep.timeout:g} s after start"})
    except KeyboardInterrupt:
        outcome.interrupted = True
        for ref in running:
            ray.cancel(ref, force=True)
    finally:
        bar.close()
