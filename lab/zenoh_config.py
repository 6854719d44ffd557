"""Zenoh configurations the lab's processes open sessions with, and the credentials they
present: shared by the clients (`lab.client_core`) and the sim process (`lab.runtime.transport`,
which adds what a server listens with), so a client imports nothing of the server.

Clients present LAB_ZENOH_USER / LAB_ZENOH_PASSWORD from their environment, over the Zenoh
configuration file LAB_ZENOH_CONFIG names (TLS: the CA to trust); docs/protocol.md, "Remote mode".
"""

import json
import os
from dataclasses import dataclass
from pathlib import Path

import zenoh

from lab.protocol import DEFAULT_ENDPOINT

ENV_USER = "LAB_ZENOH_USER"
ENV_PASSWORD = "LAB_ZENOH_PASSWORD"
ENV_CONFIG = "LAB_ZENOH_CONFIG"  # a client's Zenoh configuration file (TLS: the CA to trust)
_NO_SCOUTING = {"scouting/multicast/enabled": False, "scouting/gossip/enabled": False}


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


def zenoh_config(settings: dict[str, object], base_file: str | Path | None = None) -> zenoh.Config:
    """`settings` (keys are Zenoh configuration paths) over `base_file` or Zenoh's defaults,
    with scouting off."""
    config = zenoh.Config.from_file(str(base_file)) if base_file is not None else zenoh.Config()
    for key, value in (settings | _NO_SCOUTING).items():
        config.insert_json5(key, json.dumps(value))
    return config


def client_config(
    endpoint: str = DEFAULT_ENDPOINT, credentials: Credentials | None = None
) -> zenoh.Config:
    """Client connecting to exactly `endpoint`, no scouting; presenting `credentials`, by
    default those of LAB_ZENOH_USER / LAB_ZENOH_PASSWORD if set, over the Zenoh configuration
    file LAB_ZENOH_CONFIG names if set (TLS: the CA to trust)."""
    settings: dict[str, object] = {"mode": "client", "connect/endpoints": [endpoint]}
    credentials = credentials or credentials_from_env()
    if credentials is not None:
        settings["transport/auth/usrpwd"] = usrpwd_settings(credentials=credentials)
    return zenoh_config(settings, os.environ.get(ENV_CONFIG) or None)
