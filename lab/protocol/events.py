"""Every event a lab publishes on `lab/<id>/events`, once: a msgspec Struct per kind, tagged by
its `type` (docs/protocol.md, "lab/events"). `Event` is their union; `decode_event` reads one.

Sources: the session (`fall`, `reset`, `session_rebuilt`, `sim_diverged`, `rejected_command`
and the `solver_*` kinds), the loop (`overrun`, `stall`, the folded `rejected_command`) and
`lab replay --serve` (`replay_ended`).
"""

from typing import Annotated, Literal, get_args

import msgspec
from msgspec import Meta, Struct

SolverStatus = Literal["failed", "fallback", "capped", "violated"]


class EventStruct(Struct, frozen=True, forbid_unknown_fields=True, tag_field="type"):
    """What every event carries: its kind (`type`, the tag), sim time and a line for people."""

    t: Annotated[float, Meta(description="sim time, s")]
    message: Annotated[str, Meta(description="human-readable")]


class FallEvent(EventStruct, frozen=True, tag="fall"):
    """The robot fell: torques off, joints damped, pushes ended until `reset`."""


class ResetEvent(EventStruct, frozen=True, tag="reset"):
    """The robot was put back standing (the `reset` command)."""


class SessionRebuiltEvent(EventStruct, frozen=True, tag="session_rebuilt"):
    """A robot or scene switch rebuilt the session."""


class SimDivergedEvent(EventStruct, frozen=True, tag="sim_diverged"):
    """MuJoCo's state became invalid; the robot stands again at the same t, or is paused."""

    cause: Annotated[str, Meta(description="what was bad, e.g. 'MuJoCo: NaN, inf or huge ...'")]
    restored: Annotated[
        Literal["standing", "paused"],
        Meta(description="paused: it diverged again within 1 s (until reset or resume)"),
    ]


class RejectedCommandEvent(EventStruct, frozen=True, tag="rejected_command"):
    """Commands refused (`count` since the last such event, from the loop; the session's own
    has none)."""

    verb: Annotated[str, Meta(description="the verb (truncated)")]
    error: Annotated[str, Meta(description="the reply's error")]
    count: int | None = None


class _SolverEvent(EventStruct, frozen=True):
    status: Annotated[SolverStatus, Meta(description="telemetry's status that raised it")]
    level: Annotated[int | None, Meta(description="the stack level it concerns, or null")]
    count: Annotated[int, Meta(description="ticks since the last event of this kind")]


class SolverFailureEvent(_SolverEvent, frozen=True, tag="solver_failure"):
    """The controller failed; fallback torques (joint PD + bias) were applied."""


class SolverFallbackEvent(_SolverEvent, frozen=True, tag="solver_fallback"):
    """A level's QP failed and kept the solution of the levels above."""

    levels: Annotated[
        list[int], Meta(description="the stack levels (from 0) whose QP failed this tick")
    ] = []


class SolverCappedEvent(_SolverEvent, frozen=True, tag="solver_capped"):
    """nullspace's active-set search stopped at its cap."""


class SolverViolationEvent(_SolverEvent, frozen=True, tag="solver_violation"):
    """wbosc sent torques that violate a constraint of the stack."""


class OverrunEvent(EventStruct, frozen=True, tag="overrun"):
    """Ticks whose work ended after the next deadline (at most one event per second)."""

    count: int
    total: Annotated[int, Meta(description="overruns since start")]
    max_lateness_us: Annotated[float, Meta(description="worst lateness since the last event")]


class StallEvent(EventStruct, frozen=True, tag="stall"):
    """The loop woke more than 0.2 s after a deadline: the lost periods were skipped."""

    count: int
    seconds: Annotated[float, Meta(description="the longest stand-still since the last event")]
    skipped: Annotated[int, Meta(description="periods skipped since start (loop.skipped)")]


class ReplayEndedEvent(EventStruct, frozen=True, tag="replay_ended"):
    """`lab replay --serve` reached the end of the recording (seek to play it again)."""


Event = (
    FallEvent
    | ResetEvent
    | SessionRebuiltEvent
    | SimDivergedEvent
    | RejectedCommandEvent
    | SolverFailureEvent
    | SolverFallbackEvent
    | SolverCappedEvent
    | SolverViolationEvent
    | OverrunEvent
    | StallEvent
    | ReplayEndedEvent
)
EVENT_KINDS: tuple[str, ...] = tuple(str(cls.__struct_config__.tag) for cls in get_args(Event))


_DECODER = msgspec.json.Decoder(Event)


def decode_event(raw: bytes | object) -> Event:
    """One event from its JSON bytes or decoded object; raises msgspec.ValidationError (or
    DecodeError) saying what does not fit."""
    event: Event = _DECODER.decode(raw) if isinstance(raw, bytes) else msgspec.convert(raw, Event)
    return event
