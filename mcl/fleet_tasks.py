"""The two tasks built into every vehicle of a fleet (docs/LANGUAGE.md, "Fleets"), and nowhere
else: ``Send(CHANNEL, MESSAGE)`` and ``Receive(CHANNEL, MESSAGE[, timeout = D])``.

:func:`fleet_form` resolves such a call against the fleet's channels to a task form of its own,
which the compiler builds as any other (mcl/templates/task.py): Send ends at once with one
"send" action (the player gives it to the fleet's channel, never to the vehicle), Receive waits
for the event ``CHANNEL.MESSAGE`` and ends fail on its timeout. The checker (mcl/checker.py)
asks for it and reports what is wrong.
"""

from __future__ import annotations

from dataclasses import dataclass

from diagnostics import Span

from mcl import ast
from mcl.declarations import ActionSpec, TaskForm
from mcl.parser import suggest

FLEET_TASKS = ("Send", "Receive")
SHAPES = {"Send": "Send(CHANNEL, MESSAGE)",
          "Receive": "Receive(CHANNEL, MESSAGE[, timeout = DURATION])"}


@dataclass(frozen=True)
class FleetScope:
    """What a vehicle of a fleet may name in ``Send`` and ``Receive``: its name and the
    fleet's channels."""

    vehicle: str
    channels: dict[str, ast.ChannelDecl]


@dataclass(frozen=True)
class Problem:
    """What is wrong with a call of Send or Receive, as the checker reports it."""

    message: str
    span: Span
    hint: str
    code: str


def fleet_form(call: ast.Call, scope: FleetScope, name_span: Span
               ) -> tuple[TaskForm, ast.Value | None] | Problem:
    """The task form a call of Send or Receive resolves to, with its timeout (None: none), or
    the problem with it. ``name_span``: where the task's name stands."""
    positional = [a.value for a in call.args if a.name is None]
    named = [a for a in call.args if a.name is not None]
    allowed = ("timeout",) if call.name == "Receive" else ()
    bad = [a for a in named if a.name not in allowed]
    if (len(positional) != 2 or bad or len(named) > 1
            or any(not isinstance(v, ast.Ref) for v in positional)):
        return Problem(f"{call.name} takes a channel and one of its messages",
                       bad[0].span if bad else name_span, f"write {SHAPES[call.name]}",
                       "fleet-bad-arguments")
    channel_ref, message_ref = positional
    assert isinstance(channel_ref, ast.Ref) and isinstance(message_ref, ast.Ref)
    channel = scope.channels.get(channel_ref.name)
    if channel is None:
        return Problem(f"unknown channel '{channel_ref.name}'", channel_ref.span,
                       suggest(channel_ref.name, list(scope.channels))
                       or f"the fleet's channels: {', '.join(scope.channels) or 'none'}",
                       "fleet-unknown-channel")
    name = channel.name.name
    messages = [m.name for m in channel.messages]
    if message_ref.name not in messages:
        return Problem(f"channel '{name}' has no message '{message_ref.name}'",
                       message_ref.span, suggest(message_ref.name, messages)
                       or f"its messages: {', '.join(messages)}", "fleet-unknown-message")
    receivers = [r.name for r in channel.receivers]
    if call.name == "Send" and channel.sender.name != scope.vehicle:
        return Problem(f"{scope.vehicle} cannot send on '{name}': the channel is from "
                       f"{channel.sender.name}", channel_ref.span,
                       "send on a channel FROM this vehicle (channels are one way)",
                       "fleet-not-sender")
    if call.name == "Receive" and scope.vehicle not in receivers:
        return Problem(f"{scope.vehicle} cannot receive on '{name}': the channel is to "
                       f"{', '.join(receivers)}", channel_ref.span,
                       "receive on a channel TO this vehicle", "fleet-not-receiver")
    if call.name == "Send":
        action = ActionSpec("send", name, (("message", message_ref),), call.span)
        return TaskForm("Send", (), start=(action,), span=call.span), None
    timeout = named[0].value if named else None
    return TaskForm("Receive", (), ok=(f"{name}.{message_ref.name}",), span=call.span), timeout
