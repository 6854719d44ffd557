"""Fuzzing through the wire (hypothesis): generated commands (tests/runtime/test_fuzz.py's strategy:
every verb, plausible and wild fields, any JSON, garbage, huge and deep payloads) sent over real
Zenoh to a live loop serving a session. Every query gets an answer, `{ok: true, ...}` or
`{ok: false, error}`; nothing crashes; the loop still ticks afterwards. 2,000 examples in
`./dev test`, 10,000 in the `long` run (`./dev test -m long`: pyproject.toml's markers).

The queries go out under 64 client ids in turn (the query's attachment), so that the per-client
rate limit (100 commands/s) leaves most of them to the parser and the session; the limit and
the intake's own pace are what a single fast client meets instead (tests/runtime/test_intake.py)."""

import json
import math

import pytest
import zenoh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lab.protocol import LabKeys
from tests.helpers.fuzz import FIELD_VALUES, deep, field_names, json_values, verbs
from tests.helpers.processes import WAIT_S, LiveServer, live_server

CLIENTS = 64
REPLY_TIMEOUT_S = 20.0  # a busy machine; the intake answers refusals at once


def _encode(payload: object) -> bytes:
    """JSON as a careless client writes it: NaN and infinities as such (not JSON: refused)."""
    if isinstance(payload, bytes):  # already text (DEEP_TEXT)
        return payload
    if isinstance(payload, str) and not payload.startswith(("{", "[")):
        return payload.encode("utf-8", "surrogatepass")
    return json.dumps(payload, allow_nan=True).encode("utf-8", "surrogatepass")


# Payloads nested deeper than this are sent as text: hypothesis prints a failing example, and
# a list nested 3,000 deep is beyond its printer (and json.dumps).
DEEP_TEXT = st.sampled_from([b"[" * 3000 + b"]" * 3000, b"{" + b'"a":{' * 5000 + b"}" * 5001])
wire_wild = (
    json_values
    | st.sampled_from([deep(50)])
    | st.sampled_from([[1.0] * 100_000, ["x" * 1000] * 1000])  # huge
    | st.binary(max_size=64).map(lambda b: b.decode("latin-1"))  # binary garbage as text
)
wire_fields = {field: values | wire_wild for field, values in FIELD_VALUES.items()}


@st.composite
def wire_commands(draw: st.DrawFn) -> tuple[str, object]:
    """tests/runtime/test_fuzz.py's `commands`, deep payloads as text."""
    verb = draw(verbs)
    if draw(st.integers(0, 9)) == 0:
        return verb, draw(wire_wild | DEEP_TEXT)
    return verb, {field: draw(wire_fields[field]) for field in draw(field_names)}


def _key(keys: LabKeys, verb: str) -> str:
    """`lab/<id>/cmd/<verb>`, or a verb Zenoh takes in its place when `verb` cannot be a key
    chunk (`/`, `*`, `$`, `?`, `#`, empty: Zenoh refuses those before anything is sent; a chunk
    starting with `@` is verbatim, which the lab's `cmd/**` never matches: nothing answers)."""
    if verb and not verb.startswith("@") and not any(c in verb for c in "/*$?#"):
        try:
            return str(zenoh.KeyExpr(keys.cmd(verb)))
        except zenoh.ZError:
            pass
    return keys.cmd("not-a-key-chunk")


def _fuzz(server: LiveServer, examples: int) -> dict[str, int]:
    client = server.client
    keys = LabKeys(client.lab_id)
    session = client.session
    counts = {"ok": 0, "error": 0}
    sent = [0]

    @settings(
        max_examples=examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(wire_commands())
    def one(command: tuple[str, object]) -> None:
        verb, payload = command
        sent[0] += 1
        key = _key(keys, verb)
        replies = list(
            session.get(
                key,
                payload=_encode(payload),
                timeout=REPLY_TIMEOUT_S,
                attachment=f"fuzz-{sent[0] % CLIENTS}",
            )
        )
        assert len(replies) == 1 and replies[0].ok is not None, (verb, replies)
        body = json.loads(replies[0].ok.payload.to_bytes())
        if body.get("ok") is True:
            counts["ok"] += 1
        else:
            assert body.get("ok") is False and isinstance(body.get("error"), str), body
            assert body["error"], body
            counts["error"] += 1

    start = client.wait_telemetry()["loop"]["ticks"]
    one()
    assert server.loop.error is None, repr(server.loop.error)
    assert server.thread.is_alive()
    after = client.wait_telemetry(lambda m: m["loop"]["ticks"] > start + 50, timeout=WAIT_S)
    assert math.isfinite(after["t"])
    return counts


def test_two_thousand_generated_commands_through_zenoh_each_get_an_answer() -> None:
    with live_server("solo12") as server:
        counts = _fuzz(server, 2000)
    assert counts["ok"] + counts["error"] == 2000


@pytest.mark.long
def test_ten_thousand_generated_commands_through_zenoh_each_get_an_answer() -> None:
    with live_server("solo12") as server:
        counts = _fuzz(server, 10_000)
    assert counts["ok"] + counts["error"] == 10_000
