"""Fuzzing every verb of the protocol (hypothesis): generated commands against a running
session. Every reply is `{ok: false, error}` naming the problem or a valid success, the session
keeps ticking, and afterwards it is exactly the session that only the accepted commands reach.
2,000 commands in `./dev test`, 10,000 in the `long` run (`./dev test -m long`), as the wire
fuzz (tests/runtime/test_fuzz_wire.py).
"""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lab.world.session import Session, SessionConfig
from tests.helpers.fuzz import FIELD_VALUES, deep, field_names, json_values, verbs

BATCH = 50  # commands per generated example
TICKS_PER_COMMAND = 0.2  # one tick after every fifth command: 2,000 ticks in all


wild = (
    json_values
    | st.sampled_from([deep(300), deep(3000)])  # deep JSON (built once: building is slow)
    | st.sampled_from([[1.0] * 100_000, ["x" * 1000] * 1000])  # huge
    | st.binary(max_size=64).map(lambda b: b.decode("latin-1"))  # binary garbage as text
)


# Strategies built once: building one costs more than drawing from it.
field_or_wild = {field: values | wild for field, values in FIELD_VALUES.items()}


@st.composite
def commands(draw: st.DrawFn) -> tuple[str, object]:
    """A verb (known or not) and a payload: fields of the protocol with plausible or wild
    values (mostly), or any JSON value at all."""
    verb = draw(verbs)
    if draw(st.integers(0, 9)) == 0:
        return verb, draw(wild)
    return verb, {field: draw(field_or_wild[field]) for field in draw(field_names)}


def state_of(session: Session) -> dict:
    """Everything a command could change, as plain values."""
    q, v = session.plant.state()
    info = session.info()
    info.pop("t")
    return {
        "q": q.tolist(),
        "v": v.tolist(),
        "tau": session.tau.tolist(),
        "time": session.time,
        "info": info,
        "velocity": session.velocity.tolist(),
        "pushes": sorted(session.pushes),
    }


def _fuzz(batches: int) -> None:
    """`batches` × BATCH generated commands against a session, then the replay of the accepted
    ones into a clean session, which must end in the same state."""
    session = Session(SessionConfig(robot="anymal"))
    accepted: list[tuple[int, str, object]] = []
    counts = {"ok": 0, "rejected": 0}
    debt = 0.0

    @settings(
        max_examples=batches,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(st.lists(commands(), min_size=BATCH, max_size=BATCH))
    def batch(batch_commands: list[tuple[str, object]]) -> None:
        nonlocal debt
        for verb, payload in batch_commands:
            tick = session.ticks
            reply = session.handle(verb, payload)
            assert isinstance(reply, dict) and reply.get("ok") in (True, False), reply
            json.dumps(reply, allow_nan=False)  # a reply is plain JSON, never NaN
            if reply["ok"]:
                counts["ok"] += 1
                accepted.append((tick, verb, payload))
            else:
                counts["rejected"] += 1
                assert isinstance(reply["error"], str) and 0 < len(reply["error"]) <= 1000
            debt += TICKS_PER_COMMAND
            while debt >= 1.0:
                debt -= 1.0
                session.tick()  # never raises: the loop never stops

    batch()
    total = batches * BATCH
    assert counts["ok"] + counts["rejected"] >= total
    # both paths were exercised: at least 1 % accepted and half refused
    assert counts["ok"] >= total // 100 and counts["rejected"] >= total // 2

    # A clean session given only the accepted commands, before the same ticks, ends the same.
    clean = Session(SessionConfig(robot="anymal"))

    def tick_until(ticks: int) -> None:
        for _ in range(ticks - clean.ticks):  # bounded: a paused session does not advance
            clean.tick()
        assert clean.ticks == ticks

    for tick, verb, payload in accepted:
        tick_until(tick)
        assert clean.handle(verb, payload)["ok"]
    tick_until(session.ticks)
    ours, theirs = state_of(session), state_of(clean)
    assert ours == theirs
    assert np.all(np.isfinite(ours["q"]))


def test_two_thousand_generated_commands_change_only_what_they_are_accepted_for() -> None:
    _fuzz(40)


@pytest.mark.long
def test_ten_thousand_generated_commands_change_only_what_they_are_accepted_for() -> None:
    _fuzz(200)
