"""Remote mode: a sim process listening with `--users` admits only clients with a user:password
of its file; a non-loopback `--listen` is refused unless the configuration read back asks for a
password or serves TLS, or `--open` is given (lab/runtime/access.py).
Everything here stays on loopback: the access check does not depend on the address."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import zenoh

from lab.client import LabClient
from lab.runtime.access import (
    ListenAccess,
    is_loopback,
    listen_access,
    read_users,
    remote_listen_refusal,
)
from lab.runtime.transport import server_config
from lab.zenoh_config import ENV_CONFIG, ENV_PASSWORD, ENV_USER
from tests.helpers.ports import free_port
from tests.helpers.processes import ready_client, serve

CONNECT_S = 3.0  # a refused client gives up after this long


def test_users_files_are_read_strictly_naming_the_bad_line(tmp_path: Path) -> None:
    good = tmp_path / "users"
    good.write_text("alice:s3cret:with:colons\nbob:pw\n")
    assert [(u.user, u.password) for u in read_users(good)] == [
        ("alice", "s3cret:with:colons"),
        ("bob", "pw"),
    ]
    for text, where in (("alice:pw\n\nbob:pw\n", ":2:"), ("# users\n", ":1:"), (":pw\n", ":1:")):
        bad = tmp_path / "bad"
        bad.write_text(text)
        with pytest.raises(ValueError, match=where):
            read_users(bad)
    (tmp_path / "empty").write_text("")
    with pytest.raises(ValueError, match="no user"):
        read_users(tmp_path / "empty")


@pytest.mark.parametrize(
    ("endpoint", "loopback"),
    [
        ("tcp/127.0.0.1:7447", True),
        ("tls/127.0.0.2:7447", True),
        ("tcp/localhost:7447", True),
        ("tcp/[::1]:7447", True),
        ("tcp/0.0.0.0:7447", False),
        ("tcp/[::]:7447", False),
        ("tls/lab.example.org:7447", False),
    ],
)
def test_loopback_endpoints_are_told_apart(endpoint: str, loopback: bool) -> None:
    assert is_loopback(endpoint) is loopback


def _access(tmp_path: Path, settings: dict, listen: str = "tcp/0.0.0.0:7447") -> ListenAccess:
    """What `lab serve --listen listen --zenoh-config <settings as a file>` would check."""
    base = tmp_path / "zenoh.json5"
    base.write_text(json.dumps(settings))
    return listen_access(server_config(listen=[listen], base_file=base))


def test_only_a_configuration_that_authenticates_or_serves_tls_guards_a_remote_listen(
    tmp_path: Path,
) -> None:
    users = tmp_path / "users"
    users.write_text("alice:pw\n")
    for name in ("server.crt", "server.key"):
        (tmp_path / name).write_text("not read here: Zenoh reads it when it listens")
    tls = {"listen_certificate": str(tmp_path / "server.crt")}
    tls["listen_private_key"] = str(tmp_path / "server.key")
    guarded = [
        ({"transport": {"auth": {"usrpwd": {"dictionary_file": str(users)}}}}, "tcp/0.0.0.0:7447"),
        ({"transport": {"link": {"tls": tls}}}, "tls/0.0.0.0:7447"),
        ({"transport": {"link": {"tls": tls}}}, "quic/[::]:7447"),
    ]
    for settings, listen in guarded:
        access = _access(tmp_path, settings, listen)
        assert access.guarded and access.remote == (listen,), (settings, listen)
        assert remote_listen_refusal("lab serve", access, opened=False) is None
    usrpwd_without_file = {"transport": {"auth": {"usrpwd": {"user": "a", "password": "b"}}}}
    open_ones = [  # each looks like security and is not: (settings, listen, what the error says)
        ({}, "tcp/0.0.0.0:7447", None),
        (usrpwd_without_file, "tcp/0.0.0.0:7447", None),
        (
            {"transport": {"auth": {"usrpwd": {"dictionary_file": str(tmp_path / "none")}}}},
            "tcp/0.0.0.0:7447",
            "dictionary_file",
        ),
        ({"transport": {"link": {"tls": tls}}}, "tcp/0.0.0.0:7447", "not a tls/ or quic/"),
        ({}, "tls/0.0.0.0:7447", "has no listen_certificate"),
        (
            {"transport": {"link": {"tls": tls | {"listen_private_key": "/nonexistent.key"}}}},
            "tls/0.0.0.0:7447",
            "no such file /nonexistent.key",
        ),
    ]
    for settings, listen, problem in open_ones:
        access = _access(tmp_path, settings, listen)
        refusal = remote_listen_refusal("lab serve", access, opened=False)
        assert refusal is not None and not access.guarded, (settings, listen)
        assert f"--listen {listen}" in refusal
        for way in ("--users FILE", "--zenoh-config FILE", "TLS", "--open"):
            assert way in refusal, refusal
        assert problem is None or problem in refusal, refusal
        assert remote_listen_refusal("lab serve", access, opened=True) is None
        assert "OPEN" in access.describe()
    loopback = _access(tmp_path, {}, "tcp/127.0.0.1:7447")
    assert remote_listen_refusal("lab serve", loopback, opened=False) is None


@pytest.mark.parametrize("program", [("lab.runtime.serve", "--headless"), ("lab", "router")])
@pytest.mark.parametrize("config", [None, {}, {"transport": {"link": {"tls": {}}}}])
def test_a_non_loopback_listen_without_credentials_is_refused(
    tmp_path: Path, program: tuple[str, str], config: dict | None
) -> None:
    """Any --zenoh-config, even `{}`, used to switch the check off."""
    command = [sys.executable, "-m", *program, "--listen", "tcp/0.0.0.0:7447"]
    if config is not None:
        (tmp_path / "zenoh.json5").write_text(json.dumps(config))
        command += ["--zenoh-config", str(tmp_path / "zenoh.json5")]
    run = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2
    assert "Traceback" not in run.stderr and len(run.stderr.strip().splitlines()) == 1, run.stderr
    for way in ("--users FILE", "--zenoh-config FILE", "--open"):
        assert way in run.stderr, run.stderr


def test_the_routers_start_up_line_names_the_endpoints_it_listens_on(tmp_path: Path) -> None:
    users = tmp_path / "users"
    users.write_text("alice:pw\n")
    port = free_port()
    command = [sys.executable, "-m", "lab", "router", "--listen", f"tcp/0.0.0.0:{port}"]
    router = subprocess.Popen([*command, "--users", str(users)], stdout=subprocess.PIPE, text=True)
    try:
        line = router.stdout.readline()
    finally:
        router.terminate()
        router.wait(60)
    assert line.strip() == f"lab router: listening on tcp/0.0.0.0:{port} (users)"


def test_only_clients_with_a_listed_user_and_password_get_anything(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    users = tmp_path / "users"
    users.write_text("alice:correct horse\n")
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    server = serve(tmp_path / "serve.log", port, "--headless", "--users", str(users))
    try:
        monkeypatch.setenv(ENV_USER, "alice")
        monkeypatch.setenv(ENV_PASSWORD, "correct horse")
        with ready_client(endpoint, server) as lab:  # the right credentials: served
            assert lab.command("info")["ok"] and lab.latest_telemetry() is not None
            for password in (None, "wrong"):  # no or wrong credentials: no link at all
                monkeypatch.delenv(ENV_USER, raising=False)
                monkeypatch.delenv(ENV_PASSWORD, raising=False)
                if password is not None:
                    monkeypatch.setenv(ENV_USER, "alice")
                    monkeypatch.setenv(ENV_PASSWORD, password)
                with pytest.raises(zenoh.ZError):
                    LabClient(endpoint, connect_timeout=CONNECT_S)
            assert lab.command("info")["ok"]  # and the admitted client is still served
    finally:
        server.kill()


def _openssl(*args: str) -> None:
    subprocess.run(["openssl", *args], check=True, capture_output=True, timeout=60)


def _certificates(folder: Path) -> None:
    """A CA, and a certificate it signs for localhost / 127.0.0.1 (the openssl command)."""
    days = ("-days", "2")
    _openssl(
        "req",
        "-x509",
        "-newkey",
        "rsa:2048",
        "-nodes",
        *days,
        "-subj",
        "/CN=lab test CA",
        "-keyout",
        str(folder / "ca.key"),
        "-out",
        str(folder / "ca.crt"),
    )
    _openssl(
        "req",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-subj",
        "/CN=localhost",
        "-keyout",
        str(folder / "server.key"),
        "-out",
        str(folder / "server.csr"),
    )
    (folder / "san.cnf").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    _openssl(
        "x509",
        "-req",
        "-in",
        str(folder / "server.csr"),
        "-CA",
        str(folder / "ca.crt"),
        "-CAkey",
        str(folder / "ca.key"),
        "-CAcreateserial",
        *days,
        "-extfile",
        str(folder / "san.cnf"),
        "-out",
        str(folder / "server.crt"),
    )


@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command")
def test_over_tls_only_clients_that_trust_the_servers_ca_get_anything(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _certificates(tmp_path)
    tls = {"listen_private_key": "server.key", "listen_certificate": "server.crt"}
    server_file = tmp_path / "server.json5"
    server_file.write_text(
        json.dumps({"transport": {"link": {"tls": {k: str(tmp_path / v) for k, v in tls.items()}}}})
    )
    client_file = tmp_path / "client.json5"
    client_file.write_text(
        json.dumps(
            {"transport": {"link": {"tls": {"root_ca_certificate": str(tmp_path / "ca.crt")}}}}
        )
    )
    port = free_port()
    endpoint = f"tls/localhost:{port}"
    server = serve(
        tmp_path / "serve.log",
        port,
        "--headless",
        "--listen",
        endpoint,
        "--zenoh-config",
        str(server_file),
    )
    try:
        monkeypatch.setenv(ENV_CONFIG, str(client_file))
        with ready_client(endpoint, server) as lab:
            assert lab.command("info")["ok"] and lab.latest_telemetry() is not None
            monkeypatch.delenv(ENV_CONFIG)  # a client that does not trust the CA
            with pytest.raises(zenoh.ZError):
                LabClient(endpoint, connect_timeout=CONNECT_S)
            with pytest.raises(zenoh.ZError):  # nor one on plain TCP
                LabClient(f"tcp/localhost:{port}", connect_timeout=CONNECT_S)
    finally:
        server.kill()


def test_a_refused_login_is_told_from_a_server_that_is_down_in_one_line(tmp_path: Path) -> None:
    """Zenoh says "Unable to connect" for both; `lab teleop` says which, without a traceback."""
    users = tmp_path / "users"
    users.write_text("alice:correct horse\n")
    port, down = free_port(), free_port()
    server = zenoh.open(server_config(port, users_file=users))  # a bare peer that checks users
    cases = [
        (port, {ENV_USER: "alice", ENV_PASSWORD: "wrong"}, "wrong user or password?"),
        (port, {}, "may ask for a user and password"),
        (down, {}, f"nothing answers at tcp/127.0.0.1:{down}"),
    ]
    try:
        for to, credentials, says in cases:
            env = {k: v for k, v in os.environ.items() if k not in (ENV_USER, ENV_PASSWORD)}
            run = subprocess.run(
                [sys.executable, "-m", "lab", "teleop", "--connect", f"tcp/127.0.0.1:{to}"],
                capture_output=True,
                text=True,
                timeout=120,
                env=env | credentials,
                stdin=subprocess.DEVNULL,
            )
            assert run.returncode == 1 and run.stdout == "", run
            assert run.stderr.count("\n") == 1 and says in run.stderr, run.stderr
    finally:
        server.close()
