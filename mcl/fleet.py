"""Fleets: several vehicles in one file, coordinated by messages on channels.

A fleet file (docs/LANGUAGE.md, "Fleets") declares directed channels between vehicles and,
for each vehicle, what a single-vehicle file holds (USES, PARAM, MISSION, ON STOP). Each
vehicle's mission is checked against its own task library, with two tasks built in:
``Send(CHANNEL, MESSAGE)`` (ends at once; one transition with a "send" action) and
``Receive(CHANNEL, MESSAGE[, timeout = D])`` (waits for the event ``CHANNEL.MESSAGE``; fail
on the timeout). It compiles to one ordinary :class:`mcl.api.Compiled` per vehicle, its net
named after the vehicle, and the fleet's :class:`Channel` declarations in seconds.

The static rules of a fleet are here: names declared once, channels between declared
vehicles, delays that are durations with ``min <= max``, and no wait for ever on a lossy
channel (a Receive without timeout there must be cut short by a racing timer, the rule of
the duration analysis, mcl/analysis/duration.py); and two warnings, a message nobody sends
that a vehicle waits for, and one sent that nobody waits for. Send and Receive themselves
resolve in mcl/fleet_tasks.py.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

from diagnostics import Diagnostic, MclError, Source, Span, read_source
from petri.net import Origin

from mcl import ast, checker, compiler, parser, printer
from mcl.parser import is_fleet as is_fleet  # where it is decided (mclc loads no fleet code)
from mcl.analysis import duration
from mcl.api import Compiled, library_of
from mcl.fleet_tasks import FleetScope
from mcl.values import UNITS

BUILTIN_SOURCES = ("Link", "Mission")  # event sources a channel may not be named after


@dataclass(frozen=True)
class Channel:
    """A directed channel of a fleet, its times in seconds."""

    name: str
    sender: str
    receivers: tuple[str, ...]
    link: str  # "acoustic" | "radio" | "tether"
    delay_min: float
    delay_max: float
    interval: float  # the least time between two messages on it; 0.0 without EVERY
    lossy: bool
    messages: tuple[str, ...]
    origin: Origin

    def events(self) -> list[str]:
        """The events its messages raise at a receiver: ``CHANNEL.MESSAGE``."""
        return [f"{self.name}.{m}" for m in self.messages]


@dataclass
class CompiledFleet:
    """A compiled fleet: each vehicle's compiled mission (its net named after it) and the
    channels between them."""

    name: str
    source: Source
    vehicles: dict[str, Compiled]
    channels: dict[str, Channel]

    def receptions(self, vehicle: str) -> list[str]:
        """The ``CHANNEL.MESSAGE`` events ``vehicle`` can get: every message of every channel
        to it, in the order they are declared."""
        return [e for c in self.channels.values() if vehicle in c.receivers for e in c.events()]

    def sends(self, vehicle: str) -> list[Channel]:
        """The channels ``vehicle`` may send on."""
        return [c for c in self.channels.values() if c.sender == vehicle]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for c in self.vehicles.values() for d in c.warnings]




Params = dict[str, dict[str, tuple[ast.Value, Source]]]  # vehicle -> parameter -> value


def compile_fleet_file(path: str, params: Params | None = None,
                       require_values: bool = False) -> CompiledFleet:
    """Read, check and compile a fleet file; every problem of every vehicle is reported
    together as one :class:`MclError`. ``params``: per vehicle, values of its parameters."""
    return compile_fleet_source(read_source(path), params, require_values)


def compile_fleet_source(source: Source, params: Params | None = None,
                         require_values: bool = False) -> CompiledFleet:
    """:func:`compile_fleet_file` of a source already read (a pipe is read once)."""
    unit = parser.parse_unit(source)
    if not isinstance(unit, ast.Fleet):
        raise MclError([source.diagnostic(
            "error", "this file is a single mission, not a fleet", unit.span,
            "a fleet file starts with FLEET name { ... }", "not-a-fleet")])
    return compile_fleet(unit, source, params, require_values)


def compile_fleet(fleet: ast.Fleet, source: Source, params: Params | None = None,
                  require_values: bool = False) -> CompiledFleet:
    """A parsed fleet checked (:func:`check_fleet`), then each vehicle's mission compiled to
    its own net, named after the vehicle."""
    checked = check_fleet(fleet, source, params, require_values)
    vehicles = {}
    for name, c in checked.items():
        net = compiler.compile_mission(c)
        net.name = name
        vehicles[name] = Compiled(c.mission, c, net, source)
    return CompiledFleet(fleet.name, source, vehicles,
                         {c.name.name: _channel(c, source) for c in fleet.channels})


def check_fleet(fleet: ast.Fleet, source: Source, params: Params | None = None,
                require_values: bool = False) -> dict[str, checker.Checked]:
    """Check a parsed fleet: its declarations, then each vehicle's mission against its own
    task library with Send and Receive known. Raise one MclError with every error of every
    vehicle; each vehicle's warnings stay in its ``Checked.diagnostics``."""
    problems = declaration_problems(fleet, source)
    if problems:
        raise MclError(sorted(problems, key=_order))
    channels = {c.name.name: c for c in fleet.channels}
    params = params or {}
    unknown = sorted(set(params) - {v.name.name for v in fleet.vehicles})
    if unknown:
        raise MclError([source.diagnostic(
            "error", f"parameters given for '{unknown[0]}', which is not a vehicle of fleet "
            f"{fleet.name}", fleet.span, "vehicles: " + ", ".join(
                v.name.name for v in fleet.vehicles), "fleet-vehicle-unknown")])
    checked: dict[str, checker.Checked] = {}
    errors: list[Diagnostic] = []
    for vehicle in fleet.vehicles:
        name = vehicle.name.name
        try:
            library = library_of(vehicle.mission, source)
            checked[name] = checker.check_mission(
                vehicle.mission, library, source, params.get(name), require_values,
                fleet=FleetScope(name, channels))
        except MclError as exc:
            errors.extend(exc.diagnostics)
            continue
        errors.extend(_clashes(checked[name], channels, source))
        errors.extend(unbounded_waits(checked[name], channels))
    if errors:
        raise MclError(sorted(errors, key=_order))
    for name, diagnostics in unused_messages(checked, source).items():
        checked[name].diagnostics = sorted(checked[name].diagnostics + diagnostics,
                                           key=_order)
    return checked


def unused_messages(checked: dict[str, checker.Checked],
                    source: Source) -> dict[str, list[Diagnostic]]:
    """Warnings, by vehicle: a Receive of a message its channel's sender never sends (it can
    only end on its timeout or its race), and a message sent that no receiver waits for."""
    sent: set[str] = set()
    awaited: set[str] = set()
    for c in checked.values():
        for call in c.mission.calls():
            form = c.calls[id(call)].form
            if form.name == "Send" and call.name == "Send":
                sent.add(f"{form.start[0].behaviour}.{_message(call)}")
            elif form.name == "Receive" and call.name == "Receive":
                awaited.add(form.ok[0])
    out: dict[str, list[Diagnostic]] = {}
    for name, c in checked.items():
        for call in c.mission.calls():
            form = c.calls[id(call)].form
            if call.name == "Receive" and form.name == "Receive" and form.ok[0] not in sent:
                out.setdefault(name, []).append(source.diagnostic(
                    "warning", f"{printer.call(call)} waits for a message no vehicle sends",
                    call.span, "send it with Send(...) in the channel's sender, or remove "
                    "this wait (only its timeout or a race can end it)", "fleet-never-sent"))
            if call.name == "Send" and form.name == "Send":
                event = f"{form.start[0].behaviour}.{_message(call)}"
                if event not in awaited:
                    out.setdefault(name, []).append(source.diagnostic(
                        "warning", f"{printer.call(call)} sends a message no vehicle waits "
                        "for", call.span, "receive it with Receive(...) in a vehicle the "
                        "channel goes to, or remove this send", "fleet-never-received"))
    return out


def _message(call: ast.Call) -> str:
    """The message a checked Send names (its second argument)."""
    value = call.args[1].value
    assert isinstance(value, ast.Ref)
    return value.name


def _order(d: Diagnostic) -> tuple[int, int, int]:
    span = d.span or Span("", 0, 0)
    return (0 if d.severity == "error" else 1, span.line, span.col)


def _seconds(value: ast.Number) -> float:
    return value.value * (UNITS[value.unit][1] if value.unit else 1.0)


def _channel(decl: ast.ChannelDecl, source: Source) -> Channel:
    origin = Origin(source.name, decl.span.line, decl.span.col, f"CHANNEL {decl.name.name}",
                    "CHANNEL")
    return Channel(decl.name.name, decl.sender.name, tuple(r.name for r in decl.receivers),
                   decl.link, _seconds(decl.delay_min), _seconds(decl.delay_max),
                   _seconds(decl.every) if decl.every is not None else 0.0, decl.lossy,
                   tuple(m.name for m in decl.messages), origin)


# -- the rules of a fleet's declarations ----------------------------------------------------
def declaration_problems(fleet: ast.Fleet, source: Source) -> list[Diagnostic]:
    """What is wrong with a fleet's channels and vehicles, before any mission is checked."""
    out: list[Diagnostic] = []

    def error(message: str, span: Span, hint: str, code: str) -> None:
        out.append(source.diagnostic("error", message, span, hint, code))

    if not fleet.vehicles:
        error(f"fleet {fleet.name} has no VEHICLE", fleet.span,
              "declare each vehicle: VEHICLE name { MISSION { ... } }", "fleet-empty")
    vehicles = [v.name for v in fleet.vehicles]
    for what, refs in (("vehicle", vehicles), ("channel", [c.name for c in fleet.channels])):
        for ref, first in _repeats(refs):
            error(f"{what} '{ref.name}' is declared twice (first at {first.span})", ref.span,
                  f"give each {what} its own name", "fleet-duplicate")
    known = {v.name for v in vehicles}
    for c in fleet.channels:
        for ref, _ in _repeats(list(c.receivers)):
            error(f"'{ref.name}' is named twice as a receiver of '{c.name.name}'", ref.span,
                  "name each receiver once", "fleet-duplicate")
        for ref, _ in _repeats(list(c.messages)):
            error(f"message '{ref.name}' is declared twice on '{c.name.name}'", ref.span,
                  "name each message once", "fleet-duplicate")
        for ref in (c.sender, *c.receivers):
            if ref.name not in known:
                error(f"'{ref.name}' is not a vehicle of fleet {fleet.name}", ref.span,
                      parser.suggest(ref.name, sorted(known))
                      or f"vehicles: {', '.join(sorted(known)) or 'none'}",
                      "fleet-vehicle-unknown")
        if c.sender.name in {r.name for r in c.receivers}:
            error(f"channel '{c.name.name}' goes from {c.sender.name} to itself", c.sender.span,
                  "a channel goes from one vehicle to others", "fleet-loopback")
        if c.name.name in BUILTIN_SOURCES:
            error(f"'{c.name.name}' names the player's own events: a channel cannot be "
                  "called so", c.name.span, "choose another name", "fleet-name-clash")
        out.extend(_times(c, source))
    return out


def _repeats(refs: list[ast.Ref]) -> Iterator[tuple[ast.Ref, ast.Ref]]:
    """Each name declared again, with its first declaration."""
    seen: dict[str, ast.Ref] = {}
    for ref in refs:
        if ref.name in seen:
            yield ref, seen[ref.name]
        else:
            seen[ref.name] = ref


def _times(c: ast.ChannelDecl, source: Source) -> list[Diagnostic]:
    """DELAY lo .. hi and EVERY d: durations, finite, not negative, lo <= hi."""
    out = []
    times = [("DELAY", c.delay_min), ("DELAY", c.delay_max)]
    if c.every is not None:
        times.append(("EVERY", c.every))
    for word, n in times:
        kind = UNITS[n.unit][0] if n.unit else None
        if kind != "duration":
            why = f"{n.value:g} {n.unit} is a {kind}" if kind else f"{n.value:g} has no unit"
            out.append(source.diagnostic(
                "error", f"{word} of '{c.name.name}' takes durations: {why}", n.span,
                "write a time with its unit, e.g. DELAY 1 s .. 3 s, EVERY 2 s",
                "fleet-delay-range"))
        elif n.value < 0 or not math.isfinite(n.value):
            out.append(source.diagnostic(
                "error", f"{word} of '{c.name.name}' is negative", n.span,
                "a delay or an interval is 0 s or more", "fleet-delay-range"))
    if not out and _seconds(c.delay_min) > _seconds(c.delay_max):
        out.append(source.diagnostic(
            "error", f"DELAY of '{c.name.name}' goes from more to less", c.delay_min.span,
            "write the shortest delay first: DELAY min .. max", "fleet-delay-range"))
    return out


def _clashes(checked: checker.Checked, channels: dict[str, ast.ChannelDecl],
             source: Source) -> list[Diagnostic]:
    """A channel named as a behaviour of a vehicle it goes to would mix their events."""
    scope = checked.fleet
    assert scope is not None
    return [source.diagnostic(
        "error", f"channel '{name}' has the name of a behaviour of {scope.vehicle}'s task "
        "library: their events would mix", c.name.span, "rename the channel",
        "fleet-name-clash")
        for name, c in channels.items()
        if name in checked.library.behaviours
        and scope.vehicle in {r.name for r in c.receivers}]


def unbounded_waits(checked: checker.Checked,
                    channels: dict[str, ast.ChannelDecl]) -> list[Diagnostic]:
    """Every ``Receive`` without timeout on a LOSSY channel that nothing cuts short: no
    enclosing block has a finite worst case (a race with a timer, PARALLEL ... OR
    { Timeout(..) }, bounds it; mcl/analysis/duration.py). A lost message would leave it
    waiting for ever."""
    m = checked.mission
    out: list[Diagnostic] = []
    parts = [(m.body, duration.analyse(checked))]
    if m.on_stop is not None:
        handler = duration.stop_handler(checked)
        assert handler is not None
        parts.append((m.on_stop, handler))
    for root, bounds in parts:
        worst = {(b.construct, b.line, b.col): b.worst for b in bounds.blocks}
        for call, ancestors in _calls_with_ancestors(root):
            resolved = checked.calls.get(id(call))
            if (call.name != "Receive" or resolved is None or resolved.timeout is not None
                    or resolved.form.name != "Receive"):
                continue
            channel = channels[resolved.form.ok[0].split(".", 1)[0]]
            if not channel.lossy:
                continue
            if any(math.isfinite(worst.get((type(b).__name__, b.span.line, b.span.col),
                                           math.inf)) for b in ancestors):
                continue
            out.append(checked.source.diagnostic(
                "error", f"{printer.call(call)} may wait for ever: channel "
                f"'{channel.name.name}' is LOSSY and the message may never come", call.span,
                "give it a timeout (Receive(ch, msg, timeout = 30 s)) or race it with a "
                "timer: PARALLEL { Receive(..) } OR { Timeout(30 s) }",
                "fleet-wait-unbounded"))
    return out


def _calls_with_ancestors(root: ast.Block) -> Iterator[tuple[ast.Call, list[ast.Block]]]:
    """Every call in a block with the blocks that enclose it, innermost first."""
    stack: list[tuple[ast.Block, list[ast.Block]]] = [(root, [])]
    while stack:
        block, above = stack.pop()
        if isinstance(block, ast.Call):
            yield block, list(reversed(above))
            continue
        for child in reversed(ast.children(block)):
            stack.append((child, [*above, block]))
