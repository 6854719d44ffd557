"""Three hosts on one machine: network namespaces joined by veth pairs to a router namespace.

`lab router --users` runs in namespace R, one `lab serve --headless --users --connect` in each of
A and B (their own addresses, their own lab ids, logging in to the router as a user of the file),
and a client in C: it lists both labs, is refused without credentials and with a wrong password,
steers alpha (a velocity command accepted and seen in alpha's telemetry, not in beta's), and sees
beta keep running after alpha's sim process is killed, alpha marked offline. Each of A, B and C
has one link, to R only, on its own subnet, so everything between them goes through the router; the
namespaces are this test's own (pid-suffixed names) and are deleted at the end, failed or not.
Needs `ip netns` (root, or CAP_SYS_ADMIN and CAP_NET_ADMIN); skipped, saying why, without it.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from lab.zenoh_config import ENV_PASSWORD, ENV_USER

STARTUP_S = 90.0  # two sim processes importing MuJoCo and pinocchio at once on a busy machine
WAIT_S = 30.0  # for what takes a fraction of a second on an idle machine
PORT = 7447
SUBNET = "10.231"  # link i: SUBNET.i.1 (router side) <-> SUBNET.i.2, /24, inside the namespaces
ROLES = {"a": 1, "b": 2, "c": 3}  # the namespaces beside the router's, and their link numbers
LABS = {"a": "netns-alpha", "b": "netns-beta"}
VX = 0.2  # m/s: the velocity the client steers alpha with

USER, PASSWORD = "alice", "correct horse"  # the one line of the users file

# The client, run inside namespace C with the user's credentials in its environment. It prints
# one JSON line per step and waits for a line on stdin before the last one (the test kills
# alpha's sim in between).
CLIENT = """
import json, os, sys, time
from lab.client import LabClient
from lab.client_core import LabUnreachable

router, alpha_id, beta_id, vx, wait_s = sys.argv[1:4] + [float(a) for a in sys.argv[4:6]]

def say(**fields):
    print(json.dumps(fields), flush=True)

def until(condition, timeout):
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.05)
    return True

def refused(**credentials):
    # why a client presenting `credentials` (none: no credentials) gets no session
    saved = dict(os.environ)
    os.environ.pop("LAB_ZENOH_USER")
    os.environ.pop("LAB_ZENOH_PASSWORD")
    os.environ.update(credentials)
    try:
        LabClient(router, 3.0, alpha_id).close()
        return "admitted"
    except LabUnreachable as error:
        return str(error)
    finally:
        os.environ.clear()
        os.environ.update(saved)

with LabClient(router, wait_s, alpha_id) as alpha, LabClient(router, wait_s, beta_id) as beta:
    both = until(lambda: alpha.labs() == {alpha_id: True, beta_id: True}, 3 * wait_s)
    until(lambda: beta.latest_telemetry() is not None, wait_s)
    wrong = {"LAB_ZENOH_USER": os.environ["LAB_ZENOH_USER"], "LAB_ZENOH_PASSWORD": "wrong"}
    say(labs=alpha.labs(), both=both, without=refused(), wrong=refused(**wrong))
    reply = alpha.command("velocity", vx=vx, timeout=wait_s)
    seen = until(
        lambda: abs((alpha.latest_telemetry() or {}).get("command", {}).get("vx", 0) - vx) < 1e-6,
        wait_s,
    )
    say(reply=reply, seen=seen, beta_vx=beta.latest_telemetry()["command"]["vx"])
    sys.stdin.readline()  # alpha's sim process is killed now
    offline = alpha.wait_connected(False, wait_s)
    t0 = beta.latest_telemetry()["t"]
    time.sleep(1.0)
    beta_t = beta.wait_telemetry(timeout=wait_s)["t"]
    say(alpha_offline=offline, labs=beta.labs(), beta_advanced=beta_t - t0,
        beta_online=beta.connected)
"""


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True, timeout=WAIT_S)


class Hosts:
    """The namespaces, their links and the processes started in them; `close` undoes it all."""

    def __init__(self, tmp_path: Path) -> None:
        self.tmp_path = tmp_path
        suffix = os.getpid()
        self.names = {role: f"wbclab-{role}{suffix}" for role in ("r", *ROLES)}
        self.made: list[str] = []
        self.processes: list[subprocess.Popen] = []

    def build(self) -> None:
        router = self.names["r"]
        for name in self.names.values():
            _ip("netns", "add", name)
            self.made.append(name)
            _ip("-n", name, "link", "set", "lo", "up")
        for role, i in ROLES.items():
            host, near, far = self.names[role], f"v{role}", "v0"
            _ip("link", "add", near, "netns", router, "type", "veth", "peer", "name", far,
                "netns", host)  # fmt: skip
            _ip("-n", router, "addr", "add", f"{SUBNET}.{i}.1/24", "dev", near)
            _ip("-n", host, "addr", "add", f"{SUBNET}.{i}.2/24", "dev", far)
            _ip("-n", router, "link", "set", near, "up")
            _ip("-n", host, "link", "set", far, "up")

    def endpoint(self, role: str) -> str:
        """The router's address on `role`'s link."""
        return f"tcp/{SUBNET}.{ROLES[role]}.1:{PORT}"

    def start(self, role: str, *args: str, **popen: object) -> subprocess.Popen:
        log = (self.tmp_path / f"{role}.log").open("w")
        process = subprocess.Popen(
            ["ip", "netns", "exec", self.names[role], sys.executable, *args],
            stdout=popen.pop("stdout", log),
            stderr=log,
            text=True,
            cwd=Path(__file__).parent.parent.parent,
            **popen,  # type: ignore[arg-type]
        )
        self.processes.append(process)
        return process

    def logs(self) -> str:
        logs = sorted(self.tmp_path.glob("*.log"))
        return "\n".join(f"--- {log.name}\n{log.read_text()[-3000:]}" for log in logs)

    def close(self) -> None:
        for process in self.processes:
            if process.poll() is None:
                process.kill()
            process.wait()
        for name in self.made:
            subprocess.run(["ip", "netns", "del", name], capture_output=True, timeout=WAIT_S)


@pytest.fixture
def hosts(tmp_path: Path) -> Iterator[Hosts]:
    if shutil.which("ip") is None:
        pytest.skip("no `ip` command (iproute2) on this machine")
    made = Hosts(tmp_path)
    try:
        try:
            made.build()
        except subprocess.CalledProcessError as error:
            refused = "permitted" in error.stderr or "denied" in error.stderr
            if made.made or not refused:
                raise
            pytest.skip(f"`ip netns add` is not permitted here: {error.stderr.strip()}")
        yield made
    finally:
        made.close()
        left = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
        assert not any(name in left for name in made.names.values()), left


def _line(process: subprocess.Popen, hosts: Hosts) -> dict:
    line = process.stdout.readline()
    assert line, f"the client stopped\n{hosts.logs()}"
    return json.loads(line)


def test_a_client_in_a_third_namespace_lists_steers_and_outlives_labs(hosts: Hosts) -> None:
    users = hosts.tmp_path / "users"
    users.write_text(f"{USER}:{PASSWORD}\n")
    hosts.start("r", "-m", "lab", "router", "--users", str(users),
                *(f"--listen={hosts.endpoint(role)}" for role in ROLES))  # fmt: skip
    serve = ("-m", "lab", "serve", "--headless", "--rate", "250")  # ANYmal: the native kernel
    serve += ("--sched", "other", "--users", str(users))  # and it logs in with the first user
    sims = {
        role: hosts.start(role, *serve, "--lab-id", lab_id, "--connect", hosts.endpoint(role))
        for role, lab_id in LABS.items()
    }
    client = hosts.start(
        "c", "-c", CLIENT, hosts.endpoint("c"), LABS["a"], LABS["b"], str(VX), str(WAIT_S),
        stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        env=os.environ | {ENV_USER: USER, ENV_PASSWORD: PASSWORD},
    )  # fmt: skip
    listed = _line(client, hosts)
    assert listed["both"], f"{listed}\n{hosts.logs()}"
    # from another host, the router's port answers, and refuses a session without the password
    assert "may ask for a user and password" in listed["without"], listed
    assert "wrong user or password?" in listed["wrong"], listed
    steered = _line(client, hosts)
    assert steered["reply"]["ok"] and steered["seen"], f"{steered}\n{hosts.logs()}"
    assert steered["beta_vx"] == 0.0  # the command went to alpha only

    sims["a"].send_signal(signal.SIGKILL)
    sims["a"].wait()
    client.stdin.write("killed\n")
    client.stdin.flush()
    after = _line(client, hosts)
    assert after["alpha_offline"], f"{after}\n{hosts.logs()}"
    assert after["labs"] == {LABS["a"]: False, LABS["b"]: True}
    # at --rate 250 a 1 ms step runs 0.25 s of sim time a second: > 0.1 s in the 1 s waited
    assert after["beta_online"] and after["beta_advanced"] > 0.1, after
    assert client.wait(WAIT_S) == 0, hosts.logs()
    assert sims["b"].poll() is None, hosts.logs()
