"""Fuzzing through the wire (hypothesis): generated commands (tests/runtime/test_fuzz.py's strategy:
every verb, plausible and wild fields, any JSON, garbage, huge and deep payloads) sent over real
Zenoh to a live loop serving a session. Every query gets an answer, `{ok: true, ...}` or
`{ok: false, error}`; nothing crashes; the loop still ticks afterwards. 2,000 examples in
`./dev test`, 10,000 in the `long` run (`./dev test -m long`: pyproject.toml's markers).

The queries go out under 64 client ids in turn (the query's attachment), so that the per-client
rate limit (100 commands/s) leaves most of them to the parser and the session; the limit and
the intake's own pace are what a single fast client meets instead (tests/runtime/test_intake.py)."""

import gc
import json
import math
import sys
import traceback
from collections.abc import Iterator

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
# a list nested 3,000 deep is beyond its printer (and json.dumps). Both are under the 16 KiB cap
# (objects nested 5,000 deep were over it: refused unread, they never met the decoder).
DEEP_PAYLOADS = (b"[" * 3000 + b"]" * 3000, b"{" + b'"a":{' * 2500 + b"}" * 2501)
DEEP_TEXT = st.sampled_from(DEEP_PAYLOADS)
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


@pytest.fixture
def unraisable() -> Iterator[list["sys.UnraisableHookArgs"]]:
    """The exceptions raised where nothing catches them (a garbage collector's callback, a
    finalizer), recorded by `list.append`: a builtin, which runs at any depth of the stack, where
    pytest's own hook (Python) may fail too ("Failed to process unraisable exception")."""
    seen: list[sys.UnraisableHookArgs] = []
    hook, sys.unraisablehook = sys.unraisablehook, seen.append
    try:
        yield seen
    finally:
        sys.unraisablehook = hook


def test_deep_payloads_are_refused_before_the_decoder_recurses_to_the_interpreters_limit(
    unraisable: list["sys.UnraisableHookArgs"],
) -> None:
    """The CI failure of the fuzz above (once in many runs): the intake let the JSON decoder
    recurse into DEEP_TEXT until Python's recursion limit stopped it; a garbage collection that
    fell on the deepest levels ran the live loop's GC callback (`GcPauses`) with no stack left, and
    its RecursionError ("in comparison") was raised where nobody catches it. A collection every
    other allocation makes every decode meet one; the payloads must be refused before that. A
    callback of the test's own, which needs 20 frames of stack, stands for whatever Python a
    collection runs (GcPauses may change)."""
    collections: list[int] = []

    def frames(n: int) -> int:
        return 0 if n == 0 else 1 + frames(n - 1)

    def on_collection(phase: str, info: dict[str, int]) -> None:
        collections.append(frames(20))

    with live_server("solo12") as server:
        threshold = gc.get_threshold()
        gc.set_threshold(1, 10**6, 10**6)  # only the young generation, at once (full: seconds)
        gc.callbacks.insert(0, on_collection)  # before the loop's own
        try:
            replies = [
                server.client.request(verb, text, timeout=REPLY_TIMEOUT_S)
                for text in DEEP_PAYLOADS
                for verb in ("velocity", "info")
            ]
        finally:
            gc.callbacks.remove(on_collection)
            gc.set_threshold(*threshold)
        start = server.client.wait_telemetry()["loop"]["ticks"]
        server.client.wait_telemetry(lambda m: m["loop"]["ticks"] > start + 50, timeout=WAIT_S)
    raised = [
        f"{u.exc_type.__name__}: {u.exc_value} in {type(u.object).__name__}\n"
        + "".join(traceback.format_tb(u.exc_traceback))
        for u in unraisable
    ]
    assert not raised, raised
    assert collections  # the collections ran
    for reply in replies:
        assert reply["ok"] is False, reply
        assert "nested deeper than" in reply["error"], reply
