"""Where a lab is on Zenoh: the default endpoint, the payload caps, client and lab ids, and the
key expressions of a lab (`LabKeys`, scoped by its lab id). Standard library only."""

import re
import socket
from dataclasses import dataclass

# ---------------------------------------------------------------------------------- transport
DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
# Of one command's JSON payload. The largest valid command (a stack of 64 task names of 128
# characters) is under 10 KiB; the cap is checked before a payload is read (issue 25).
MAX_PAYLOAD_BYTES = 16 * 1024
# Of its lists and objects, nested: the deepest valid command (a stack: an object of a list of
# lists) nests 3 deep. Deeper payloads are refused before they are decoded: a decoder stopped only
# by Python's recursion limit left any garbage collection that fell on its deepest levels, and
# the callbacks and finalizers it ran, without stack (lab/runtime/intake.py).
MAX_PAYLOAD_DEPTH = 32
# A client's id: the attachment of each of its command queries (docs/protocol.md, "Clients").
CLIENT_ID_PATTERN = re.compile(r"[A-Za-z0-9_.-]{1,64}")

# ---------------------------------------------------------------------------------- key expressions
# Every key of a sim process is scoped by its lab id, `lab/<id>/...`, so several labs share one
# Zenoh network (a router) without hearing each other's commands. A lab id is one key chunk.
LAB_ID_PATTERN = re.compile(r"[A-Za-z0-9_.-]{1,64}")
# Liveliness tokens of every lab: a client lists the labs it can see by this key expression.
ALL_LABS_ALIVE = "lab/*/alive"


class LabIdError(ValueError):
    """A lab id that cannot be a key chunk (empty, too long, or with `/`, `*`, `$`, ...)."""


@dataclass(frozen=True)
class LabKeys:
    """The key expressions of the lab `lab_id` (docs/protocol.md, "Key expressions")."""

    lab_id: str

    def __post_init__(self) -> None:
        if not LAB_ID_PATTERN.fullmatch(self.lab_id):
            raise LabIdError(
                f"lab id {self.lab_id!r}: 1-64 characters of letters, digits, '_', '.', '-'"
            )

    @property
    def root(self) -> str:
        return f"lab/{self.lab_id}"

    @property
    def cmd_prefix(self) -> str:
        """A command is a query on `cmd_prefix + verb`."""
        return f"{self.root}/cmd/"

    def cmd(self, verb: str) -> str:
        return self.cmd_prefix + verb

    @property
    def telemetry(self) -> str:
        return f"{self.root}/telemetry"

    @property
    def state(self) -> str:
        return f"{self.root}/state"

    @property
    def events(self) -> str:
        return f"{self.root}/events"

    def client(self, client_id: str) -> str:
        """The liveliness token a client holds while its link to the lab is up: the control
        lock is released when its holder's token vanishes (docs/protocol.md)."""
        return f"{self.root}/clients/{client_id}"

    @property
    def clients(self) -> str:
        """Every client's liveliness token (`client`)."""
        return f"{self.root}/clients/*"

    @property
    def alive(self) -> str:
        """A liveliness token the sim process holds while it runs: clients see it appear and
        vanish (Zenoh removes it when the process dies or the link to it breaks), which is how
        they say "disconnected"."""
        return f"{self.root}/alive"


def lab_id_of(key: str) -> str | None:
    """The lab id of a key `lab/<id>/...`; None for any other key."""
    parts = key.split("/")
    if len(parts) < 3 or parts[0] != "lab" or not LAB_ID_PATTERN.fullmatch(parts[1]):
        return None
    return parts[1]


def default_lab_id(robot: str, host: str | None = None) -> str:
    """`<host>-<robot>`, characters a key chunk cannot hold replaced by '-': the id of a sim
    process started without `--lab-id` (host: this machine's name)."""
    host = socket.gethostname() if host is None else host
    return re.sub(r"[^A-Za-z0-9_.-]", "-", f"{host}-{robot}")[:64]
