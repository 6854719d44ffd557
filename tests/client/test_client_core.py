"""One client core (lab/client_core.py) under every client: `LabClient`, `lab teleop` (on
LabClient) and the UI's link open their sessions, select labs and send commands through
`LabLink`, and none of them imports the server."""

import subprocess
import sys

import pytest

import lab.client_core
from lab.client import LabClient
from lab.teleop import teleop_main
from lab.ui.link import Link


class _Opened(Exception):
    """Raised by the patched core in place of opening a Zenoh session."""


def test_labclient_teleop_and_the_ui_link_open_their_session_through_the_core(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    opened: list[str] = []

    def open_session(endpoint: str, *_: object, **__: object) -> None:
        opened.append(endpoint)
        raise _Opened(endpoint)

    monkeypatch.setattr(lab.client_core, "open_session", open_session)
    with pytest.raises(_Opened):
        LabClient("tcp/127.0.0.1:1")
    with pytest.raises(_Opened):
        Link("tcp/127.0.0.1:2")
    with pytest.raises(_Opened):
        teleop_main(["--connect", "tcp/127.0.0.1:3"])
    assert opened == ["tcp/127.0.0.1:1", "tcp/127.0.0.1:2", "tcp/127.0.0.1:3"]


def test_no_client_imports_the_server() -> None:
    """`lab.client` once imported `lab.runtime.transport` for its Zenoh configuration."""
    code = (
        "import sys, lab.client, lab.teleop, lab.ui.link\n"
        "server = ('lab.world', 'lab.runtime', 'lab.experiments', 'lab.recording')\n"
        "print(sorted(m for m in sys.modules if m.startswith(server)))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert result.stdout.strip() == "[]", result.stdout


def test_the_protocol_is_light() -> None:
    """Every process imports lab.protocol: it brings neither numpy, Zenoh, pinocchio nor MuJoCo,
    nor any other part of the lab."""
    code = (
        "import sys, lab.protocol, lab.protocol.schema\n"
        "heavy = {'numpy', 'zenoh', 'pinocchio', 'mujoco'}\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in heavy\n"
        "             or m.startswith('lab.') and not m.startswith('lab.protocol')))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert result.stdout.strip() == "[]", result.stdout
