"""Who may talk to the sim process when it listens beyond loopback (remote mode).

Zenoh's user/password authentication: the sim process reads a file of `user:password` lines
(`lab serve --users FILE`) and refuses a link from anyone who does not present one of them;
clients present theirs from LAB_ZENOH_USER / LAB_ZENOH_PASSWORD. Encryption (TLS) and access
control lists are Zenoh's own configuration (`lab serve --zenoh-config FILE`; a client's in
LAB_ZENOH_CONFIG). A non-loopback
`--listen` with none of these is refused unless asked for with `--open`. docs/protocol.md,
"Remote mode".
"""

import os
import re
from dataclasses import dataclass
from pathlib import Path

ENV_USER = "LAB_ZENOH_USER"
ENV_PASSWORD = "LAB_ZENOH_PASSWORD"
ENV_CONFIG = "LAB_ZENOH_CONFIG"  # a client's Zenoh configuration file (TLS: the CA to trust)
_LOOPBACK_HOST = re.compile(r"^(127\.\d+\.\d+\.\d+|localhost|\[::1\])$")


@dataclass(frozen=True)
class Credentials:
    """A user and password that a Zenoh session presents when it opens a link."""

    user: str
    password: str

    def env(self) -> dict[str, str]:
        """The environment variables that hand these credentials to a child process."""
        return {ENV_USER: self.user, ENV_PASSWORD: self.password}


def credentials_from_env() -> Credentials | None:
    """Credentials from LAB_ZENOH_USER and LAB_ZENOH_PASSWORD, or None when they are unset."""
    user, password = os.environ.get(ENV_USER), os.environ.get(ENV_PASSWORD)
    return Credentials(user, password) if user and password is not None else None


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


def usrpwd_settings(
    users_file: str | Path | None = None, credentials: Credentials | None = None
) -> dict[str, str]:
    """Zenoh's `transport/auth/usrpwd`: the users it accepts, the credentials it presents."""
    settings = {}
    if users_file is not None:
        settings["dictionary_file"] = str(Path(users_file).resolve())
    if credentials is not None:
        settings |= {"user": credentials.user, "password": credentials.password}
    return settings


def remote_listen_refusal(
    program: str, listen: list[str], secured: bool, opened: bool
) -> str | None:
    """Why `program` refuses to listen where other machines reach it: no `--users` or
    `--zenoh-config` (`secured`) nor `--open`; None when it may."""
    remote = [endpoint for endpoint in listen if not is_loopback(endpoint)]
    if not remote or secured or opened:
        return None
    return (
        f"{program}: --listen {remote[0]} is reachable from other machines: admit users with "
        "--users FILE (and/or TLS with --zenoh-config FILE), or pass --open "
        "(docs/protocol.md, 'Remote mode')"
    )
