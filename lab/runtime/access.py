"""Who may talk to the sim process when it listens beyond loopback (remote mode).

Zenoh's user/password authentication: the sim process reads a file of `user:password` lines
(`lab serve --users FILE`) and refuses a link from anyone who does not present one of them;
clients present theirs from LAB_ZENOH_USER / LAB_ZENOH_PASSWORD. Encryption (TLS) and access
control lists are Zenoh's own configuration (`lab serve --zenoh-config FILE`; a client's in
LAB_ZENOH_CONFIG). A non-loopback `--listen` is refused unless the configuration the session
opens with (read back, `listen_access`: not the flags nor the presence of a file) asks
users for a password or serves TLS, or unless asked for with `--open`. docs/protocol.md,
"Remote mode".
"""

import json
import re
from dataclasses import dataclass
from pathlib import Path

import zenoh

from lab.zenoh_config import Credentials

_LOOPBACK_HOST = re.compile(r"^(127\.\d+\.\d+\.\d+|localhost|\[::1\])$")


def read_users(path: str | Path) -> list[Credentials]:
    """The users of a users file: one `user:password` per line and nothing else (Zenoh reads
    the file itself and refuses blank or comment lines). Raises ValueError naming the file and
    line of a malformed one, or a file with no user."""
    users = []
    for number, line in enumerate(Path(path).read_text().splitlines(), start=1):
        user, colon, password = line.partition(":")
        if not colon or not user or not password:
            raise ValueError(f"{path}:{number}: expected user:password")
        users.append(Credentials(user, password))
    if not users:
        raise ValueError(f"{path}: no user:password line")
    return users


def is_loopback(endpoint: str) -> bool:
    """Whether a Zenoh endpoint (`tcp/127.0.0.1:7447`, `tls/[::1]:7447`, ...) is on loopback."""
    address = endpoint.split("/", 1)[-1].split("#", 1)[0]
    host = address.rsplit(":", 1)[0]
    return bool(_LOOPBACK_HOST.match(host))


def local_endpoint(endpoint: str) -> str:
    """Where a process on this host reaches a session listening on `endpoint` (all
    interfaces, `0.0.0.0` or `[::]`, reached on loopback)."""
    return endpoint.replace("/0.0.0.0:", "/127.0.0.1:").replace("/[::]:", "/[::1]:")


TLS_PROTOCOLS = ("tls", "quic")  # Zenoh's links that take transport/link/tls's certificate
LISTEN_TLS_FILES = ("listen_certificate", "listen_private_key")


@dataclass(frozen=True)
class ListenAccess:
    """Who may connect to a Zenoh session, read from its merged configuration (what it will
    listen on and what it checks), not assumed from the flags or files that made it."""

    endpoints: tuple[str, ...]  # the listen endpoints of the session's mode
    remote: tuple[str, ...]  # those reachable from other machines
    users: bool  # transport/auth/usrpwd with a dictionary file of at least one user
    tls: bool  # every remote endpoint tls/ or quic/, with a listen certificate and key
    mtls: bool  # TLS that also asks clients for a certificate signed by root_ca_certificate
    problems: tuple[str, ...]  # settings that look like security and are not, and why

    @property
    def guarded(self) -> bool:
        """Whether a link from another machine is checked: a password, or TLS (which proves
        the server to clients, and with mTLS the clients to the server)."""
        return self.users or self.tls

    def describe(self) -> str:
        """The endpoints and what guards them, for a start-up line."""
        guards = ["users"] if self.users else []
        if self.tls:
            guards.append("mTLS" if self.mtls else "TLS")
        if not self.remote:
            guard = "loopback only"
        elif guards:
            guard = " + ".join(guards)
            if self.tls and not self.mtls and not self.users:
                guard += ": the server proves itself, clients do not"
        else:
            guard = "OPEN: no authentication"
        return f"{', '.join(self.endpoints)} ({guard})"


def listen_access(config: zenoh.Config) -> ListenAccess:
    """Read `config` (the one the session opens with, the lab's settings merged in) for what
    it listens on and what it asks of whoever connects: a usrpwd dictionary file that exists
    and names users, or TLS certificates on tls/quic endpoints."""
    mode = json.loads(config.get_json("mode") or "null") or "peer"
    listen = json.loads(config.get_json("listen/endpoints") or "null") or []
    endpoints = tuple(listen.get(mode, []) if isinstance(listen, dict) else listen)
    remote = tuple(endpoint for endpoint in endpoints if not is_loopback(endpoint))
    problems: list[str] = []
    usrpwd = json.loads(config.get_json("transport/auth/usrpwd") or "null") or {}
    users = False
    if dictionary := usrpwd.get("dictionary_file"):
        try:
            users = bool(read_users(dictionary))
        except (OSError, ValueError) as error:
            problems.append(f"transport/auth/usrpwd/dictionary_file: {error}")
    tls_settings = json.loads(config.get_json("transport/link/tls") or "null") or {}
    tls = bool(remote)
    for endpoint in remote:
        protocol = endpoint.split("/", 1)[0]
        settings = tls_settings | _endpoint_settings(endpoint)
        missing = [key for key in LISTEN_TLS_FILES if not settings.get(key)]
        if protocol not in TLS_PROTOCOLS:
            tls = False
            if tls_settings.get("listen_certificate"):
                problems.append(
                    f"{endpoint} is not a tls/ or quic/ endpoint: its certificate is unused"
                )
        elif missing:
            tls = False
            problems.append(f"{endpoint}: transport/link/tls has no {' or '.join(missing)}")
        elif absent := [settings[k] for k in LISTEN_TLS_FILES if not Path(settings[k]).is_file()]:
            tls = False
            problems.append(f"{endpoint}: no such file {absent[0]}")
    mtls = (
        tls
        and bool(tls_settings.get("enable_mtls"))
        and bool(tls_settings.get("root_ca_certificate"))
    )
    return ListenAccess(endpoints, remote, users, tls, mtls, tuple(problems))


def _endpoint_settings(endpoint: str) -> dict[str, str]:
    """An endpoint's own configuration (`tls/host:port#key=value;key=value`)."""
    config = endpoint.partition("#")[2]
    return dict(item.partition("=")[::2] for item in config.split(";") if "=" in item)


def remote_listen_refusal(program: str, access: ListenAccess, opened: bool) -> str | None:
    """Why `program` refuses to listen where other machines reach it with nothing that
    authenticates who connects (`access`, read from its configuration) and no `--open`;
    None when it may."""
    if not access.remote or access.guarded or opened:
        return None
    problems = "".join(f"; {problem}" for problem in access.problems)
    return (
        f"{program}: --listen {access.remote[0]} is reachable from other machines and nothing "
        f"authenticates who connects{problems}. Either admit users with --users FILE, or give "
        "--zenoh-config FILE that sets up authentication (transport.auth.usrpwd.dictionary_file) "
        "or TLS (a tls/ or quic/ endpoint with transport.link.tls.listen_certificate and "
        "listen_private_key), or pass --open to run without (docs/protocol.md, 'Remote mode')"
    )
