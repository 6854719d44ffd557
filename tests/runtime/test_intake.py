"""The command intake's bookkeeping without Zenoh: per-client queues served round-robin, the
rate limit, the size cap, validation. `tests/client/test_client.py` drives it through real Zenoh."""

import json
import threading

import pytest
import zenoh

from lab.protocol import MAX_PAYLOAD_BYTES, MAX_PAYLOAD_DEPTH, LabKeys, parse_command
from lab.runtime.intake import (
    BURST,
    CLIENT_QUEUE,
    INTAKE_BURST,
    INTAKE_RATE_HZ,
    RATE_HZ,
    REFUSAL_COST,
    STAND_ASIDE_S,
    TICK_ALLOWANCE_S,
    CommandIntake,
    nesting_depth,
)

KEYS = LabKeys("intake")


class _Bytes:
    def __init__(self, data: bytes) -> None:
        self.data = data

    def __len__(self) -> int:
        return len(self.data)

    def to_bytes(self) -> bytes:
        return self.data


class _Query:
    """What the intake reads of a zenoh.Query."""

    def __init__(self, verb: str, payload: dict | bytes, client: str | None) -> None:
        self.key_expr = KEYS.cmd(verb)
        raw = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
        self.payload = _Bytes(raw)
        self.attachment = None if client is None else _Bytes(client.encode())


class _ClosedQueryable:
    def recv(self) -> None:
        raise zenoh.ZError("closed")


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _intake(clock: _Clock) -> tuple[CommandIntake, list[tuple[object, dict]]]:
    answers: list[tuple[object, dict]] = []
    intake = CommandIntake(
        _ClosedQueryable(), KEYS, parse_command, lambda q, body: answers.append((q, body)), clock
    )
    intake.join(5.0)  # its thread ended at once: only `receive` below feeds it
    return intake, answers


def test_clients_are_served_in_turn_whatever_one_of_them_sends() -> None:
    intake, answers = _intake(_Clock())
    for _ in range(CLIENT_QUEUE):
        intake.receive(_Query("pause", {}, "flood"))
    intake.receive(_Query("resume", {}, "calm"))
    taken = [intake.take() for _ in range(CLIENT_QUEUE + 1)]
    assert [r.client for r in taken[:3]] == ["flood", "calm", "flood"]
    assert intake.take() is None and not answers


def test_a_full_queue_a_fast_client_and_a_large_payload_are_refused_with_the_reason() -> None:
    clock = _Clock()
    intake, answers = _intake(clock)
    for _ in range(CLIENT_QUEUE + 1):
        intake.receive(_Query("pause", {}, "a"))
    assert f"busy: {CLIENT_QUEUE} commands of client a" in answers[-1][1]["error"]
    for _ in range(BURST):  # the bucket is empty now
        intake.receive(_Query("info", {}, "a"))
    assert (
        "rate limit" in answers[-1][1]["error"]
        and f"{RATE_HZ:g} commands/s" in (answers[-1][1]["error"])
    )
    clock.now += 1.0  # refilled: served again (its queue has room once the loop takes)
    intake.take()
    refused = len(answers)
    intake.receive(_Query("info", {}, "a"))
    assert len(answers) == refused  # accepted: it waits, unanswered
    big = b'{"vx": ' + b" " * MAX_PAYLOAD_BYTES + b"1}"
    read = intake.payload_bytes
    intake.receive(_Query("velocity", big, "b"))
    assert f"over the {MAX_PAYLOAD_BYTES}-byte cap" in answers[-1][1]["error"]
    assert intake.payload_bytes - read == len(big)  # refused, but counted (heap_trim.py)
    count, verb, error = intake.rejections()
    assert count == len(answers) and verb == "velocity" and "cap" in error
    assert intake.rejections()[0] == 0


def test_no_query_is_begun_just_before_the_loops_tick() -> None:
    clock, slept = _Clock(), []
    intake = CommandIntake(
        _ClosedQueryable(), KEYS, parse_command, lambda q, body: None, clock, sleep=slept.append
    )
    intake.join(5.0)
    intake.stand_aside()  # no loop to stand aside for
    deadline = 1.0
    intake.stand_aside_for(lambda: deadline)
    for now in (deadline - 2 * STAND_ASIDE_S, deadline + 2 * TICK_ALLOWANCE_S):
        clock.now = now
        intake.stand_aside()  # far from the tick, or well after it began: no sleep
    assert slept == []
    clock.now = deadline - STAND_ASIDE_S / 2  # about to begin: sleep until it is under way
    intake.stand_aside()
    assert slept == [pytest.approx(STAND_ASIDE_S / 2 + TICK_ALLOWANCE_S)]


class _Queries:
    """A queryable's channel holding `queries`, closed after them; none is given before
    `opened` is set."""

    def __init__(self, queries: list[_Query]) -> None:
        self.queries, self.opened = queries, threading.Event()

    def recv(self) -> _Query:
        self.opened.wait()
        if not self.queries:
            raise zenoh.ZError("closed")
        return self.queries.pop(0)


def _paced(count: int, valid: bool) -> tuple[float, list[dict]]:
    """How long (on the intake's clock) its thread takes to read `count` queries from 64
    clients in turn (none over its rate), valid or not, and the answers it gives; the loop
    (here its `sleep`) takes what waits."""
    clock, answers, intakes = _Clock(), [], []
    queries = [_Query("pause", {} if valid else b"[", f"c{i % 64}") for i in range(count)]

    def sleep(seconds: float) -> None:
        clock.now += seconds
        while intakes and intakes[0].take():
            pass

    def answer(query: object, body: dict) -> None:
        answers.append(body)

    channel = _Queries(queries)
    intakes.append(CommandIntake(channel, KEYS, parse_command, answer, clock, sleep=sleep))
    # Opened once `sleep` can reach the intake: its thread starts in the constructor, and the
    # commands it read before then were never taken (their queues filled, "busy" was answered).
    channel.opened.set()
    intakes[0].join(30.0)
    assert not queries
    return clock.now, answers


def test_refusals_are_answered_at_a_fraction_of_the_pace_of_valid_commands() -> None:
    """The intake reads valid commands at INTAKE_RATE_HZ and refusals at INTAKE_RATE_HZ /
    REFUSAL_COST (a flood's queries it does not read are dropped by Zenoh's channel)."""
    # Its burst and then one second's worth of each.
    elapsed, answers = _paced(int(INTAKE_BURST + INTAKE_RATE_HZ), valid=True)
    assert elapsed == pytest.approx(1.0, abs=0.01) and answers == []
    count = int((INTAKE_BURST + INTAKE_RATE_HZ) / REFUSAL_COST)
    elapsed, answers = _paced(count, valid=False)
    assert elapsed == pytest.approx(1.0, abs=0.01) and len(answers) == count
    assert all("not valid JSON" in answer["error"] for answer in answers)


def test_only_valid_commands_wait_for_the_loop() -> None:
    intake, answers = _intake(_Clock())
    intake.receive(_Query("velocity", {"vx": 99}, "a"))
    intake.receive(_Query("velocity", {"vx": 0.5}, "a"))
    assert answers[0][1] == {"ok": False, "error": answers[0][1]["error"]}
    assert "'vx'" in answers[0][1]["error"] and len(answers) == 1
    request = intake.take()
    assert request.command.vx == 0.5 and intake.take() is None


def _nested(depth: int) -> object:
    value: object = {"levels": [["com"]]}  # 3 deep, the deepest valid command
    for _ in range(depth - 3):
        value = [value]
    return value


def test_a_payload_nested_deeper_than_the_cap_is_refused_before_it_is_decoded() -> None:
    intake, answers = _intake(_Clock())
    intake.receive(_Query("stack", _nested(MAX_PAYLOAD_DEPTH), "a"))  # decoded: not an object
    assert "payload must be a JSON object, got list" in answers[-1][1]["error"]
    for text in (
        json.dumps(_nested(MAX_PAYLOAD_DEPTH + 1)).encode(),
        b"[" * 3000 + b"]" * 3000,
        b"{" + b'"a":{' * 2500 + b"}" * 2501,
        b"[" * MAX_PAYLOAD_BYTES,  # never closed: the decoder would recurse before it knew
    ):
        intake.receive(_Query("stack", text, "a"))
        depth = text.count(b"[") + text.count(b"{")
        assert answers[-1][1] == {
            "ok": False,
            "error": f"stack: payload is nested deeper than {MAX_PAYLOAD_DEPTH} lists and "
            f"objects ({depth} levels)",
        }
    # Brackets inside strings do not nest: refused for what they are.
    intake.receive(_Query("robot", {"name": "[{" * 40}, "a"))
    assert "field 'name'" in answers[-1][1]["error"]


def test_nesting_depth_counts_what_the_decoder_would_enter() -> None:
    assert nesting_depth(b"1") == nesting_depth(b'"[[["') == 0
    assert nesting_depth(b'{"levels": [["a", "b"], ["c"]]}') == 3
    assert nesting_depth(b'[{"k[": "}]\\\\"}, [[]]]') == 3  # brackets in keys and strings
    assert nesting_depth(b'["\\\\\\"[[", [[1]]]') == 3  # an escaped quote ends no string
    assert nesting_depth(b'"\\\\"[[') == 2  # an escaped backslash does not escape the quote
    assert nesting_depth(b'["unterminated [[[[') == 1
