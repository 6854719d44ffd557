"""The server starts its UI process at a lower CPU priority than itself (the sim loop's
deadlines come first on a 2-core machine)."""

import os
import sys

import pytest

from lab.server.serve import UI_NICENESS, _start_ui


@pytest.mark.skipif(not hasattr(os, "getpriority"), reason="no process priorities here")
def test_the_ui_process_runs_nicer_than_the_server() -> None:
    own = os.getpriority(os.PRIO_PROCESS, 0)
    child = _start_ui([sys.executable, "-c", "import time; time.sleep(30)"], dict(os.environ))
    try:
        assert os.getpriority(os.PRIO_PROCESS, child.pid) == min(19, own + UI_NICENESS)
    finally:
        child.kill()
        child.wait()
