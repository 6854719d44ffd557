"""`lab serve`: the sim process (session + realtime loop + Zenoh) and, unless --headless, the UI
process (`python -m lab.ui`). SIGINT/SIGTERM stop both cleanly."""

import argparse
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import zenoh

from lab.protocol import DEFAULT_PORT, FLOOR_SECONDS_MAX, LabIdError, LabKeys, default_lab_id
from lab.runtime.access import local_endpoint
from lab.runtime.loop import SimLoop
from lab.runtime.loop_config import SPIN_CHOICES, LoopConfig
from lab.runtime.scheduling import AUTO_FIFO_MIN_CPUS, SCHED_CHOICES, SLICE_MAX_S, SLICE_MIN_S
from lab.runtime.transport import AccessError, ServerTransport, checked_server_config

UI_STOP_TIMEOUT_S = 2.0
UI_RESTART_DELAY_S = 2.0  # a UI process that died is started again after this long
# The machine's floor at start-up (issue 31): long enough for a figure to 0.05 points (2000
# ticks), short enough not to keep the page waiting; its ticks come before the sim's.
FLOOR_S = 2.0
FLOOR_WAIT_MARGIN_S = 3.0  # the UI starts anyway this long after the floor should have ended
AUTO_SPIN = "auto"


def _spin_ms(text: str) -> float | str:
    """`--spin-ms`: a number of ms or `auto`."""
    if text == AUTO_SPIN:
        return AUTO_SPIN
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of ms nor auto: {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="lab serve", description=__doc__)
    p.add_argument("--robot", default="anymal", help="robot to start with (default: anymal)")
    p.add_argument("--scene", default="flat", help="scene to start with (default: flat)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT, help="TCP port on 127.0.0.1")
    p.add_argument(
        "--lab-id",
        help="the id that scopes this lab's Zenoh keys, lab/<id>/... (default: <host>-<robot>); "
        "several labs behind one router need different ones",
    )
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="listen on this Zenoh endpoint instead of 127.0.0.1 (opt-in, e.g. tcp/0.0.0.0:7447)",
    )
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="also connect to this Zenoh endpoint (opt-in, e.g. a router)",
    )
    p.add_argument(
        "--users",
        metavar="FILE",
        help="admit only Zenoh links that present a user:password line of FILE (remote mode; "
        "clients set LAB_ZENOH_USER and LAB_ZENOH_PASSWORD)",
    )
    p.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="a Zenoh configuration (TLS, access control) the lab's settings are written over",
    )
    p.add_argument(
        "--open",
        action="store_true",
        help="allow a non-loopback --listen with neither --users nor authentication or TLS in "
        "--zenoh-config",
    )
    p.add_argument(
        "--record",
        metavar="FILE.mcap",
        help="record telemetry, state, events and commands with their replies to an MCAP file",
    )
    p.add_argument(
        "--record-dir",
        default="recordings",
        metavar="DIR",
        help="where the `record` command (the page's Record button) writes (default: recordings)",
    )
    p.add_argument("--rate", type=float, default=1000.0, help="loop rate in Hz (default: 1000)")
    p.add_argument("--fast", action="store_true", help="no sleeping: run as fast as possible")
    p.add_argument(
        "--sched",
        choices=SCHED_CHOICES,
        default="auto",
        help="scheduling of the sim loop: fifo asks for SCHED_FIFO, other keeps SCHED_OTHER, auto "
        f"(default) is fifo with {AUTO_FIFO_MIN_CPUS} or more CPUs, else other (a FIFO loop on "
        "fewer starves the UI and a local browser)",
    )
    p.add_argument(
        "--spin-ms",
        type=_spin_ms,
        default=AUTO_SPIN if LoopConfig.adaptive_spin else LoopConfig.spin_s * 1e3,
        help="ms before each deadline the loop spins instead of sleeping; the whole period "
        "(1 at 1 kHz) never sleeps and keeps a CPU busy; auto: a margin learned from how late "
        "the loop's sleeps end (p99.5 over the last 2 s) "
        f"(default: {'auto' if LoopConfig.adaptive_spin else f'{LoopConfig.spin_s * 1e3:g}'})",
    )
    p.add_argument(
        "--warm",
        action="store_true",
        help="let the session warm its next tick in the spin before each deadline "
        "(MuJoCo's forward dynamics on a scratch copy of the state: a shorter tick for more "
        "of the loop's CPU; default: off)",
    )
    p.add_argument(
        "--spin",
        choices=SPIN_CHOICES,
        default=LoopConfig.spin,
        help="how the loop spends the spin: yield (sched_yield) or busy (reads the clock only) "
        f"(default: {LoopConfig.spin})",
    )
    p.add_argument(
        "--slice-ms",
        type=float,
        default=None if LoopConfig.slice_s is None else LoopConfig.slice_s * 1e3,
        help="the EEVDF slice the loop asks for at SCHED_OTHER (Linux >= 6.12; "
        f"{SLICE_MIN_S * 1e3:g}-{SLICE_MAX_S * 1e3:g}; 0: the kernel's default) "
        f"(default: {'0' if LoopConfig.slice_s is None else f'{LoopConfig.slice_s * 1e3:g}'})",
    )
    p.add_argument(
        "--nice",
        type=int,
        default=LoopConfig.nice,
        help="the nice value the loop asks for at SCHED_OTHER (-20..19; below 0 needs "
        f"CAP_SYS_NICE, refused quietly without) (default: {LoopConfig.nice})",
    )
    p.add_argument(
        "--switch-interval-ms",
        type=float,
        default=LoopConfig.switch_interval_s * 1e3,
        help="the interpreter's switch interval while the loop runs (ms): how long the loop "
        "waits at most for the GIL another thread holds; 0: Python's default (5) "
        f"(default: {LoopConfig.switch_interval_s * 1e3:g})",
    )
    p.add_argument(
        "--floor-s",
        type=float,
        default=FLOOR_S,
        help="measure the machine's floor (the loop's on-time fraction with nothing to do) for "
        "this long before the sim starts and the UI is started; 0: not at start (the `floor` "
        f"command measures it any time); --fast never does (default: {FLOOR_S:g})",
    )
    p.add_argument("--telemetry-hz", type=float, default=100.0)
    p.add_argument("--state-hz", type=float, default=60.0)
    p.add_argument(
        "--switch-worker",
        action="store_true",
        help="build a robot switch's robot and MuJoCo model in a worker process that keeps the "
        "last 8 (measured, not the default: docs/reliability.md, 'Robot switches')",
    )
    p.add_argument("--headless", action="store_true", help="do not start the browser UI")
    p.add_argument("--ui-port", type=int, default=8080, help="HTTP port of the browser UI")
    return p


def serve_main(argv: list[str]) -> int:
    args = build_parser().parse_args(argv)
    if args.rate <= 0 or args.telemetry_hz <= 0 or args.state_hz <= 0:
        print("lab serve: --rate, --telemetry-hz and --state-hz must be positive", file=sys.stderr)
        return 2
    if args.spin_ms != AUTO_SPIN and not 0 <= args.spin_ms <= 1e3 / args.rate:
        print("lab serve: --spin-ms must be auto or between 0 and the period", file=sys.stderr)
        return 2
    if not 0 <= args.floor_s <= FLOOR_SECONDS_MAX:
        print(f"lab serve: --floor-s must be 0-{FLOOR_SECONDS_MAX:g}", file=sys.stderr)
        return 2
    if args.switch_interval_ms < 0:
        print("lab serve: --switch-interval-ms must be 0 or positive", file=sys.stderr)
        return 2
    if args.nice is not None and not -20 <= args.nice <= 19:
        print("lab serve: --nice must be -20..19", file=sys.stderr)
        return 2
    if (
        args.slice_ms is not None
        and args.slice_ms != 0
        and not (SLICE_MIN_S * 1e3 <= args.slice_ms <= SLICE_MAX_S * 1e3)
    ):
        print(
            f"lab serve: --slice-ms must be 0 or {SLICE_MIN_S * 1e3:g}-{SLICE_MAX_S * 1e3:g}",
            file=sys.stderr,
        )
        return 2
    lab_id = args.lab_id or default_lab_id(args.robot)
    try:
        LabKeys(lab_id)
    except LabIdError as error:
        print(f"lab serve: --lab-id: {error}", file=sys.stderr)
        return 2
    try:
        config, access, ui_credentials = checked_server_config(
            "lab serve", args.port, args.listen, args.connect, args.users, args.zenoh_config,
            args.open,
        )  # fmt: skip
    except AccessError as error:
        print(error, file=sys.stderr)
        return 2
    from lab.runtime.gain_designer import GainDesigner
    from lab.world.memory import map_large_blocks
    from lab.world.session import Session, SessionConfig  # heavy: MuJoCo, pinocchio

    map_large_blocks()  # what a robot switch frees is given back to the system (memory.py)
    designer = GainDesigner()  # LQR gains designed off the loop (issue 26 item 2)
    try:
        session = Session(SessionConfig(robot=args.robot, scene=args.scene), designer.submit)
    except KeyError as error:
        designer.close()
        print(f"lab serve: {error.args[0]}", file=sys.stderr)
        return 2
    if note := session.controller.kernel_note:
        print(f"lab serve: {note}: the Python kernel runs", file=sys.stderr)
    try:
        transport = ServerTransport(config, lab_id)
    except zenoh.ZError as error:  # a port in use, a Zenoh configuration it cannot use
        designer.close()
        print(f"lab serve: Zenoh: {error}", file=sys.stderr)
        return 2
    from lab.recording.record import Recorder, RecordingTransport
    from lab.runtime.switch import Switcher

    recorder = None
    if args.record:
        try:
            recorder = Recorder(args.record, session)
        except OSError as error:
            transport.close()
            designer.close()
            print(f"lab serve: --record: {error}", file=sys.stderr)
            return 2
    recording = RecordingTransport(
        transport, session, Path(args.record_dir), recorder, args.record and Path(args.record)
    )
    loop = SimLoop(
        session,
        recording,
        LoopConfig(
            rate_hz=args.rate,
            fast=args.fast,
            sched=args.sched,
            spin_s=LoopConfig.spin_s if args.spin_ms == AUTO_SPIN else args.spin_ms * 1e-3,
            adaptive_spin=args.spin_ms == AUTO_SPIN,
            floor_s=args.floor_s,
            spin=args.spin,
            warm=args.warm,
            slice_s=args.slice_ms * 1e-3 if args.slice_ms else None,
            nice=args.nice,
            switch_interval_s=args.switch_interval_ms * 1e-3 or None,
            telemetry_hz=args.telemetry_hz,
            state_hz=args.state_hz,
        ),
        switcher=(switcher := Switcher(worker=args.switch_worker, nice=args.nice)),
    )
    if not args.fast:  # a fast loop has no deadline to keep
        transport.stand_aside_for(lambda: loop.next_deadline)
    switcher.keep(session.config)  # a switch back to the first robot loads it (switch.py)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    thread = threading.Thread(target=loop.run, args=(stop,), name="sim-loop")
    thread.start()
    if loop.floor.running:  # the UI process would load the machine while it is measured
        loop.floor.finished.wait(args.floor_s + FLOOR_WAIT_MARGIN_S)
    ui = None
    try:
        endpoint = local_endpoint(access.endpoints[0])  # the UI runs on this host
        ui_command = [sys.executable, "-m", "lab.ui", "--connect", endpoint, "--exit-with-parent"]
        ui_command += ["--port", str(args.ui_port), "--lab-id", lab_id]
        ui_env = os.environ | (ui_credentials.env() if ui_credentials else {})
        if not args.headless:
            ui = subprocess.Popen(ui_command, env=ui_env)
        mode = "fast" if args.fast else f"{args.rate:g} Hz, SCHED_{loop.wanted_sched.upper()}"
        if not args.fast and args.sched == "auto":
            mode += " (auto)"
        if loop.floor.result is not None:
            mode += f", floor {loop.floor.result['on_time_fraction']:.2%} on time"
        print(
            f"lab serve: lab {lab_id}: {args.robot} on {args.scene}, {mode}, "
            f"Zenoh {access.describe()}",
            flush=True,
        )
        ui_died_at = None
        while not stop.wait(0.5):
            if ui is None or ui.poll() is None:
                continue
            # The UI process died (killed, crashed): the sim runs on; start a new UI, whose
            # page the browser reconnects to (docs/reliability.md).
            if ui_died_at is None:
                ui_died_at = time.monotonic()
                print(
                    f"lab serve: the UI process exited ({ui.returncode}); restarting it", flush=True
                )
            elif time.monotonic() - ui_died_at >= UI_RESTART_DELAY_S:
                ui, ui_died_at = subprocess.Popen(ui_command, env=ui_env), None
    finally:
        stop.set()
        thread.join()
        switcher.close()
        transport.close()
        recording.close()
        designer.close()
        if ui is not None:
            stop_process(ui)
    if loop.error is not None:
        print(f"lab serve: the sim loop stopped: {loop.error!r}", file=sys.stderr)
        return 1
    return 0


def stop_process(process: subprocess.Popen) -> None:
    """Terminate `process` (the UI), killing it if it does not end within UI_STOP_TIMEOUT_S."""
    process.terminate()
    try:
        process.wait(UI_STOP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


if __name__ == "__main__":
    sys.exit(serve_main(sys.argv[1:]))
