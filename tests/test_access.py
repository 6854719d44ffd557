"""Remote mode: a sim process listening with `--users` admits only clients with a user:password
of its file; a non-loopback `--listen` without credentials is refused (lab/server/access.py).
Everything here stays on loopback: the access check does not depend on the address."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import zenoh
from ports import free_port
from test_faults import ready_client, serve

from lab.client import LabClient
from lab.server.access import ENV_CONFIG, ENV_PASSWORD, ENV_USER, is_loopback, read_users

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


@pytest.mark.parametrize("program", [("lab.server.serve", "--headless"), ("lab", "router")])
def test_a_non_loopback_listen_without_credentials_is_refused(program: tuple[str, str]) -> None:
    run = subprocess.run(
        [sys.executable, "-m", *program, "--listen", "tcp/0.0.0.0:7447"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2
    assert "--users FILE" in run.stderr and "--open" in run.stderr, run.stderr


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
