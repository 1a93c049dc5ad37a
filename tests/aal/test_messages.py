"""The AAL message schemas (aal/messages.py): ActionMessage and EventMessage round-trip through
JSON; every malformed or invalid message is refused with InvalidMessage naming the field.
"""

from __future__ import annotations

import json
from typing import Any

import pytest

from aal.messages import ActionMessage, EventMessage, InvalidMessage


# -- the AAL message schemas ---------------------------------------------------------------
GOOD_ACTION = {"v": 1, "seq": 17, "t": 12.503, "mission": "dam_inspection",
               "task": "GoTo@12:9", "kind": "enable", "behaviour": "GoTo",
               "params": {"x": 1.0}}
GOOD_EVENT = {"v": 1, "seq": 42, "t": 12.9, "source": "GoTo", "name": "reached", "data": {}}


def edited(d: dict[str, Any], **changes: Any) -> str:
    out = dict(d)
    for k, v in changes.items():
        if v is ...:
            out.pop(k)
        else:
            out[k] = v
    return json.dumps(out)


def test_valid_messages_round_trip() -> None:
    a = ActionMessage.from_json(json.dumps(GOOD_ACTION))
    assert a == ActionMessage(17, 12.503, "dam_inspection", "GoTo@12:9", "enable", "GoTo",
                              {"x": 1.0})
    assert ActionMessage.from_json(a.to_json()) == a
    e = EventMessage.from_json(json.dumps(GOOD_EVENT).encode())
    assert e.event == "GoTo.reached"
    assert EventMessage.from_json(e.to_json()) == e
    assert EventMessage.from_json(edited(GOOD_EVENT, t=3)).t == 3.0  # an int time is fine


BAD_ACTIONS = {
    "not JSON": "{",
    "not an object": '"enable"',
    "bytes not UTF-8": b"\xff\xfe{}",
    "wrong version": edited(GOOD_ACTION, v=2),
    "no version": edited(GOOD_ACTION, v=...),
    "missing seq": edited(GOOD_ACTION, seq=...),
    "missing params": edited(GOOD_ACTION, params=...),
    "seq a float": edited(GOOD_ACTION, seq=1.0),
    "seq a bool": edited(GOOD_ACTION, seq=False),
    "seq negative": edited(GOOD_ACTION, seq=-3),
    "t a string": edited(GOOD_ACTION, t="12"),
    "t infinite": json.dumps(GOOD_ACTION).replace("12.503", "Infinity"),
    "behaviour a number": edited(GOOD_ACTION, behaviour=3),
    "params a list": edited(GOOD_ACTION, params=[]),
    "unknown kind": edited(GOOD_ACTION, kind="explode"),
    "too large": edited(GOOD_ACTION, params={"x": "a" * 70_000}),
}
BAD_EVENTS = {
    "not JSON": "nope",
    "wrong version": edited(GOOD_EVENT, v="1"),
    "missing name": edited(GOOD_EVENT, name=...),
    "missing data": edited(GOOD_EVENT, data=...),
    "name a number": edited(GOOD_EVENT, name=7),
    "source not a name": edited(GOOD_EVENT, source="Go To"),
    "name with a dot": edited(GOOD_EVENT, name="reached.twice"),
    "data a string": edited(GOOD_EVENT, data="{}"),
    "t NaN": json.dumps(GOOD_EVENT).replace("12.9", "NaN"),
}


@pytest.mark.parametrize("text", list(BAD_ACTIONS.values()), ids=list(BAD_ACTIONS))
def test_invalid_actions_are_refused_with_invalid_message(text: str | bytes) -> None:
    with pytest.raises(InvalidMessage):
        ActionMessage.from_json(text)


@pytest.mark.parametrize("text", list(BAD_EVENTS.values()), ids=list(BAD_EVENTS))
def test_invalid_events_are_refused_with_invalid_message(text: str) -> None:
    with pytest.raises(InvalidMessage):
        EventMessage.from_json(text)


def test_invalid_message_says_which_field() -> None:
    with pytest.raises(InvalidMessage, match="'seq'"):
        EventMessage.from_json(edited(GOOD_EVENT, seq="x"))
    with pytest.raises(InvalidMessage, match="'params' is missing"):
        ActionMessage.from_json(edited(GOOD_ACTION, params=...))
    with pytest.raises(InvalidMessage, match="version"):
        ActionMessage.from_json(edited(GOOD_ACTION, v=0))

