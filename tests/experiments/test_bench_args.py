"""`lab bench` says which robot, gait and method combinations it leaves out, and refuses a
request where none go together (no run: these are argument checks, fast)."""

import pytest

from lab.experiments.bench import bench_main


def test_a_request_with_nothing_to_time_is_refused_naming_why(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert bench_main(["--robots", "bolt", "--gaits", "trot", "--kernels", "python"]) == 2
    err = capsys.readouterr().err
    assert "gait 'trot' is timed on anymal" in err and "nothing to time" in err


def test_wbosc_on_a_quadruped_is_said_not_silently_dropped(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["--robots", "anymal", "--gaits", "stand", "--methods", "wbosc", "--kernels", "python"]
    assert bench_main(argv) == 2
    assert "wbosc is timed on bolt only" in capsys.readouterr().err
