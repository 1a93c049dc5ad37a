"""The structural route: verification of missions too large to enumerate, by construction
and on the syntax tree.

The verification model is petri/verification/properties.py's (docs/METHODS.md): the
environment delivers any awaited event or lets any timer expire at any moment; a block is
aborted only by the construct that contains it; the external stop, ``Mission.abort``, is
verified separately. MCL nets are block-structured: every block is an instance of a template
with the begin/abort -> ok/fail/aborted interface (docs/DESIGN.md §5). So this route

1. verifies, by explicit reachability, each template the mission uses with *generic* children
   (blocks that may end ok or fail at any moment; the mission's PARALLEL arity up to
   :data:`MAX_ARITY`, wider ones sharing the template's symmetric structure), one variant with
   a latched behaviour inside and one with a child that ends at once, with
   petri/verification/properties.py: every property must hold, stop-safe included (the
   external stop aborts the template at any moment, and it and zero-time firings alone must
   end the mission with every behaviour off). This establishes one-safe, proper-completion,
   no-deadlock and stop-safe for the whole mission (given that mcl/analysis/latches.py's data
   flow, which prunes the latch transitions the compiler makes, over-approximates: the
   explicit route checks that on random missions) — this module;
2. decides ``can-end`` and Zeno behaviour exactly, by an outcome analysis on the syntax tree
   (mcl/analysis/outcomes.py), and ``terminates`` (every run ends) from the proved worst-case
   duration (mcl/analysis/termination.py, the same decision as the explicit route's);
3. decides the behaviour properties on the syntax tree, over-approximating: a violation it
   reports may be a false alarm, but it misses none (mcl/analysis/clashes.py).

Anything it cannot establish is reported ``undecided`` (``no-dead-transitions`` always is: the
state space is not enumerated).
"""

from __future__ import annotations

import time
from dataclasses import replace
from functools import cache

from diagnostics import Source
from petri.net import Net
from petri.verification.properties import Result, Verdict, actions_match, undecided, verify

from mcl import ast
from mcl.analysis import clashes, outcomes, termination
from mcl.api import compile_source
from mcl.checker import Checked
from mcl.compiler import compile_mission
from mcl.tasklib import load

MAX_ARITY = 3


# -- 1. templates verified with generic children --------------------------------------------
def _template_keys(mission: ast.Mission) -> list[tuple[str, int]]:
    keys: set[tuple[str, int]] = set()
    if mission.on_stop is not None:
        keys.add(("STOP", 1))
    for b in (b for part in mission.parts() for b in ast.walk(part)):
        match b:
            case ast.Sequence(items=items):
                keys.add(("SEQ", min(len(items), 3)))
            case ast.TryCatchDo():
                keys.add(("TRY", 3))
            case ast.ParallelAnd(branches=bs):
                keys.add(("AND", min(len(bs), MAX_ARITY)))
            case ast.ParallelOr(branches=bs):
                keys.add(("OR", min(len(bs), MAX_ARITY)))
            case ast.IfThenElse(else_=e):
                keys.add(("IF", 3 if e is not None else 2))
            case ast.WhileDo():
                keys.add(("WHILE", 2))
    keys.add(("TASK", 1))
    return sorted(keys)


def _generic_mission(kind: str, arity: int, variant: str) -> str:
    names = ["A()", "B()", "C()", "D()"][:arity]
    if variant == "latch":
        names[0] = "Lamp(enable); " + names[0] + "; Lamp(disable)"
    elif variant == "at-once":
        names[0] = "Now()"
    blocks = ["{ " + n + " }" for n in names]
    if kind == "STOP":  # the mission template with a stop handler
        body, handler = (names[0], "B()") if variant != "at-once" else ("A()", "Now()")
        return f"MISSION {{ {body} }} ON STOP {{ {handler} }}"
    match kind:
        case "TASK":
            body = names[0]
        case "SEQ":
            body = "; ".join(n for n in names)
            if variant == "latch":
                body = "TRY { " + body + " } CATCH { D() } DO { Now() }"
        case "TRY":
            body = f"TRY {blocks[0]} CATCH {blocks[1]} DO {blocks[2]}"
        case "AND" | "OR":
            body = "PARALLEL " + f" {kind} ".join(blocks)
        case "IF":
            body = f"IF {blocks[0]} THEN {blocks[1]}" + (f" ELSE {blocks[2]}" if arity == 3 else "")
        case "WHILE":
            body = f"WHILE {blocks[0]} DO {blocks[1]}"
        case _:
            raise ValueError(kind)
    return f"MISSION {{ {body} }}"


@cache
def template_check(kind: str, arity: int) -> tuple[bool, int, str]:
    """Verify one template with generic children (three variants); (ok, markings, detail).
    Every error-level property the explicit route checks must hold, stop-safe included (the
    generic children can always fail, so loops can end), but ``terminates``: a generic child
    may end ok for ever, so a WHILE template has a loop; the mission's own timeouts decide
    whether it ends (mcl/analysis/termination.py)."""
    library = load(["generic"])
    markings = 0
    for variant in ("generic", "at-once", "latch"):
        text = _generic_mission(kind, arity, variant)
        net = compile_source(Source(f"<template {kind}>", text), library=library).net
        verdict = verify(net)
        markings += verdict.markings
        bad = [f"{r.name} {r.status}" for r in verdict.results
               if not r.holds and r.severity == "error" and r.name != "terminates"]
        if not any(r.name == "stop-safe" for r in verdict.results):
            bad.append("stop-safe not checked by the explicit route")
        if bad:
            return False, markings, f"{text}: {', '.join(bad)}"
    return True, markings, ""


def analyse(checked: Checked, net: Net | None = None, note: str = "") -> Verdict:
    """Structural verification of a checked mission; returns a Verdict like
    petri/verification/properties.py's. ``net``: the mission's compiled net (compiled here if
    not given); ``note``: added to each method (e.g. why this route was chosen)."""
    start = time.perf_counter()
    if net is None:
        net = compile_mission(checked)
    verdict = Verdict(net, 0, 0, 0.0)
    suffix = f" ({note})" if note else ""
    body = checked.mission.body
    verdict.results += by_construction(checked.mission, suffix)
    out = outcomes.Outcomes(checked)
    reach = out.reachable(body)
    ends = termination.result(checked)  # every run ends: decided from the worst case
    ends.method += suffix
    verdict.results.append(ends)
    verdict.results += outcomes.results(out, body, reach, outcomes.METHOD + suffix)
    verdict.results += clashes.results(checked, out, body, reach, clashes.METHOD + suffix)
    if checked.mission.on_stop is not None:
        verdict.results = with_stop_handler(checked, out, verdict.results, suffix)
    verdict.results.append(actions_match(net))
    verdict.results.append(undecided("no-dead-transitions", "not checked: the state space is "
                                     "not enumerated", "not established" + suffix,
                                     severity="warning"))
    verdict.seconds = time.perf_counter() - start
    return verdict


def with_stop_handler(checked: Checked, out: outcomes.Outcomes, results: list[Result],
                      suffix: str) -> list[Result]:
    """The body's results, each replaced by the stop handler's where the handler breaks the
    property. The handler runs alone (the body has stopped and everything is off), so it is
    analysed as a mission of its own. Whether it ends is ``stop-ends`` (its worst case);
    ``stop-safe`` holds by construction: a second stop halts it (the STOP template)."""
    handler = checked.mission.on_stop
    assert handler is not None
    reach = out.reachable(handler)
    found = outcomes.results(out, handler, reach, outcomes.METHOD + suffix)
    found += clashes.results(checked, out, handler, reach, clashes.METHOD + suffix)
    broken = {r.name: r for r in found if not r.holds and r.name != "can-end"}
    merged = []
    for r in results:
        h = broken.get(r.name)
        if h is None or (not r.holds and not r.undecided):  # the body's violation stays
            merged.append(r)
        else:
            merged.append(replace(h, name=r.name, severity=r.severity,
                                  message=f"in the stop handler (ON STOP): {h.message}"))
    return merged


def by_construction(mission: ast.Mission, suffix: str = "") -> list[Result]:
    """The properties that hold for the whole mission when every template it uses holds
    them with generic children (part 1); ``suffix``: added to the method."""
    keys = _template_keys(mission)
    checked_templates = [(k, template_check(*k)) for k in keys]
    bad = [(k, r) for k, r in checked_templates if not r[0]]
    total = sum(r[1] for _, r in checked_templates)
    shown = ", ".join(k if k in ("TASK", "TRY", "WHILE", "STOP") else f"{k}×{a}"
                      for (k, a), _ in checked_templates)
    how = (f"by construction: each template used ({shown}) verified with generic children, "
           f"{total} markings in all{suffix}")
    goods = {"one-safe": "every place holds at most one token",
             "proper-completion": "the mission ends with exactly one token, in MISSION.ok or "
                                  "MISSION.fail",
             "no-deadlock": "no reachable marking is stuck before the mission ends",
             "stop-safe": "from every marking, the external stop ends the mission at once "
                          "with every behaviour off"}
    if bad:
        why = f"a template fails with generic children, so nothing follows by construction: " \
              f"{bad[0][1][2]}"
        return [undecided(name, why, how) for name in goods]
    return [Result(name, True, "error", good, how) for name, good in goods.items()]
