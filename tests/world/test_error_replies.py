"""Every error reply starts with its verb (docs/protocol.md, "Replies"): each verb is sent
payloads that fail in the parser (shape, type, range) and in the session (a name it does not
know, a value this robot cannot take), and every refusal reads `<verb>: ...`."""

from lab.protocol import VERBS
from lab.world.session import Session, SessionConfig

# Payloads each verb refuses in the session, after parsing: names it does not know, values out of
# this robot's reach. (Before, 13 kinds of them answered "unknown robot 'x' ...", no verb.)
SESSION_REFUSED: dict[str, list[dict]] = {
    "robot": [{"name": "nope"}],
    "scene": [{"name": "nope"}, {"name": "block"}],  # a scene made for Talos only
    "hierarchy": [
        {"method": "nope"},
        {"method": "cascade", "solver": "nope"},
        {"method": "cascade", "formulation": "nope"},
        {"kernel": "nope"},
    ],
    "stack": [{"preset": "nope"}, {"levels": [["nope"]]}],
    "gains": [{"task": "nope", "kp": 1.0}],
    "gait": [{"name": "nope"}, {"name": "trot", "footholds": "nope"}],
    "momentum": [{"mode": "nope"}],
    "internal_force": [{"source": "nope"}],
    "stance": [{"side": "left"}],  # ANYmal has no flat soles
    "hand": [{"name": "left", "position": [0.0, 0.0, 1.0]}],  # ANYmal has no hands
    "push": [{"body": "nope", "force": [1.0, 0.0, 0.0], "duration": 0.1}],
    "record": [{"action": "start"}],  # a session without a recorder
    "floor": [{}],  # a session without a realtime loop
    "payload": [{"body": "nope", "mass": 1.0}],
}
# Payloads every verb's parser refuses: not an object, a field no verb has, keys not strings.
PARSER_REFUSED = [[], "text", 3, {"zzz": 1}, {1: 2}]


def test_every_error_reply_starts_with_its_verb() -> None:
    session = Session(SessionConfig(robot="anymal"))
    refusals = 0
    for verb in (*VERBS, "nope", "x" * 300):
        payloads = [*PARSER_REFUSED, *SESSION_REFUSED.get(verb, [])]
        for payload in payloads:
            reply = session.handle(verb, payload)
            assert not reply["ok"], (verb, payload, reply)
            assert reply["error"].startswith(f"{verb[:64]}: "), (verb, payload, reply)
            refusals += 1
    assert refusals == (len(VERBS) + 2) * 5 + sum(map(len, SESSION_REFUSED.values()))
    for event in session.pop_events():  # and the events say it once
        if event["type"] == "rejected_command":
            assert not event["message"].startswith(f"{event['verb']}: {event['verb']}:"), event
