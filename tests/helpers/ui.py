"""A session served to an in-process viser server for the page's logic, and that server as a fixture
(tests/conftest.py imports it) (from tests/ui/test_ui_logic.py)."""

import pytest


@pytest.fixture(scope="module")
def viser_server():
    import viser

    from tests.helpers.ports import free_port

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    yield server
    server.stop()


class _SessionHost:
    """A command host that applies commands to an in-process session (the sim process's way)."""

    def __init__(self, session) -> None:
        self.session = session
        self.sent: list[tuple[str, dict]] = []

    def guard(self, callback):
        return callback

    def send(self, client, verb: str, payload: dict) -> dict:
        self.sent.append((verb, payload))
        return self.session.handle(verb, payload)
