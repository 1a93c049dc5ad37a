"""The kinds of vehicle ``mcl run --vehicle KIND[:WHERE]`` runs a mission on (docs/VEHICLES.md).

Each kind is one module of this package that supplies what :class:`.kind.Kind` names (its
name, what follows ``NAME:``, its options, its constructor); :data:`KINDS` lists them, in the
order ``mcl run --help`` shows them. A new kind is one new file and one line in :data:`KINDS`
(docs/EXTENDING.md, "Add a kind of vehicle").
"""

from __future__ import annotations

import argparse
import difflib
import importlib
from types import ModuleType

from app.vehicles.kind import Invalid, Kind, Options, Vehicle

__all__ = ["KINDS", "Invalid", "Kind", "Options", "Vehicle", "add_options", "build",
           "help_text", "kinds", "usage"]

KINDS: list[str] = [  # one module of app/vehicles/ each
    "sim",      # the simulated Ictineu, in process (the default)
    "script",   # a scripted vehicle: a TOML file of answers
    "zenoh",    # a vehicle served by 'mcl vehicle --zenoh', over Zenoh
    "mavlink",  # an ArduSub-class vehicle, over MAVLink 2
]

Owned = dict[str, list[argparse.Action]]  # a kind's name -> the options it added


def kinds() -> list[Kind]:
    """The modules :data:`KINDS` names, each checked to supply what a kind must."""
    out: list[Kind] = []
    for name in KINDS:
        module: ModuleType = importlib.import_module(f"{__name__}.{name}")
        if not isinstance(module, Kind):
            missing = [m for m in ("NAME", "WHERE", "HELP", "TITLE", "INJECT", "add_options",
                                   "build") if not hasattr(module, m)]
            raise TypeError(f"app/vehicles/{name}.py is not a kind of vehicle: it lacks "
                            f"{', '.join(missing)} (see app/vehicles/kind.py)")
        out.append(module)
    return out


def usage(kind: Kind) -> str:
    return f"{kind.NAME}:{kind.WHERE}" if kind.WHERE else kind.NAME


def help_text() -> str:
    """``--vehicle``'s help: every kind, what it takes and what it is."""
    return " or ".join(f"{usage(k)} ({k.HELP})" for k in kinds())


def add_options(parser: argparse.ArgumentParser) -> Owned:
    """Each kind's options, in a group of its own; returns which kind added which."""
    owned: Owned = {}
    for kind in kinds():
        options = Options(parser.add_argument_group(kind.TITLE))
        kind.add_options(options)
        owned[kind.NAME] = options.actions
    return owned


def build(args: argparse.Namespace, owned: Owned) -> Vehicle:
    """The vehicle ``args.vehicle`` names, built from ``args``; :class:`Invalid` if it names
    no kind, or if the run gives an option of another kind or an ``--inject`` it does not take."""
    name, _, where = str(args.vehicle).partition(":")
    known = kinds()
    chosen = next((k for k in known if k.NAME == name and (k.WHERE or not where)), None)
    if chosen is None:
        names = [usage(k) for k in known]
        listed = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else names[0]
        near = difflib.get_close_matches(name, [k.NAME for k in known], n=1, cutoff=0.6)
        mean = f"did you mean {usage(next(k for k in known if k.NAME == near[0]))}? " if near \
            else ""
        raise Invalid(f"--vehicle {args.vehicle}: unknown kind of vehicle: {mean}use {listed}")
    for kind in known:
        if kind is chosen:
            continue
        given = [a for a in owned.get(kind.NAME, [])
                 if getattr(args, a.dest, a.default) != a.default]
        if given:
            raise Invalid(f"{given[0].option_strings[0]} is for --vehicle "
                          f"{kind.NAME}{':...' if kind.WHERE else ''}; "
                          f"this run's vehicle is {args.vehicle!r}")
    if getattr(args, "inject", None) and chosen.INJECT is not None:
        raise Invalid(chosen.INJECT)
    return chosen.build(where, args)
