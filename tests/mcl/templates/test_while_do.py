"""mcl/templates/while_do.py: ``WHILE {C} DO {B}``, arc by arc.

The condition runs; ok runs the body, fail ends the loop ok; a body that ends ok starts the
condition again, one that fails ends the loop fail. An abort stops the part that runs. The
loop's origin carries its condition as written, for the verifier's message on a loop that
cannot end.
"""

from __future__ import annotations

from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled

W, COND, BODY = "WHILE@2:3", "A@2:11", "B@2:22"


def test_the_loop_goes_round_until_the_condition_fails() -> None:
    net = compiled("WHILE { A() } DO { B() }")
    assert arcs(net, f"{W}.start") == ([f"{W}.begin"], [f"{COND}.begin", f"{W}.while"])
    assert arcs(net, f"{W}.cond_ok") == ([f"{COND}.ok", f"{W}.while"], [f"{BODY}.begin", f"{W}.do"])
    assert arcs(net, f"{W}.cond_fail") == ([f"{COND}.fail", f"{W}.while"], [f"{W}.ok"])
    assert arcs(net, f"{W}.body_ok") == ([f"{BODY}.ok", f"{W}.do"],
                                         [f"{COND}.begin", f"{W}.while"])  # again
    assert arcs(net, f"{W}.body_fail") == ([f"{BODY}.fail", f"{W}.do"], [f"{W}.fail"])


def test_an_abort_stops_the_condition_or_the_body() -> None:
    net = compiled("WHILE { A() } DO { B() }")
    for role, child in (("while", COND), ("do", BODY)):
        assert arcs(net, f"{W}.abort_{role}") == ([f"{W}.abort", f"{W}.{role}"],
                                                  [f"{child}.abort", f"{W}.stop_{role}"])
        assert absorbed(net, f"{W}.stop_{role}", child, f"{W}.stop_{role}") == [f"{W}.aborted"]


def test_the_origin_carries_the_condition_on_one_line() -> None:
    net = compiled("WHILE { A(); Now() } DO { B() }")
    start = next(t for t in net.transitions if t.name == f"{W}.start")
    assert start.origin is not None
    assert (start.origin.kind, start.origin.text) == ("WHILE", "WHILE { A(); Now() }")


def test_the_while_alone_verifies() -> None:
    verdict = verify(compiled("WHILE { A() } DO { Lamp(enable); B(); Lamp(disable) }"))
    # its generic children may end ok for ever: only a mission's timeouts bound the loop, so
    # every property holds but terminates (a plain net's graph rule: a reachable cycle)
    assert [r.name for r in verdict.results if r.severity == "error" and not r.holds] == [
        "terminates"]
