"""What the tests of the templates share: a construct compiled on its own with the generic
task library, and the arcs of a transition by place names."""

from __future__ import annotations

from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from petri.net import Net

# A() .. D() end ok or fail on an event (or are aborted); Now() ends at once; Lamp latches.
GENERIC = tasklib.load(["generic"])


def compiled(body: str) -> Net:
    """``MISSION {`` newline, two spaces, ``body``, newline ``}``: the body starts at 2:3."""
    return compile_source(Source("m.mcl", f"MISSION {{\n  {body}\n}}\n"), library=GENERIC).net


def arcs(net: Net, transition: str) -> tuple[list[str], list[str]]:
    """The names of the input and of the output places of a transition, each sorted."""
    tr = next(t for t in net.transitions if t.name == transition)
    return (sorted(net.places[p].name for p, _ in tr.inputs),
            sorted(net.places[p].name for p, _ in tr.outputs))


def absorbed(net: Net, name: str, child: str, waiting: str) -> list[str]:
    """Where the three transitions that absorb ``child``'s abort (``{name}.stopped``,
    ``.late_ok``, ``.late_fail``) lead, checking they wait on ``waiting`` and the child."""
    outs = []
    for suffix, needs in (("stopped", ["aborted"]), ("late_ok", ["ok", "abort"]),
                          ("late_fail", ["fail", "abort"])):
        inputs, outputs = arcs(net, f"{name}.{suffix}")
        assert inputs == sorted([waiting] + [f"{child}.{n}" for n in needs]), suffix
        outs.append(",".join(outputs))
    assert len(set(outs)) == 1, outs  # all three lead to the same place(s)
    return outs[0].split(",")


def names(net: Net, prefix: str) -> list[str]:
    """The transitions whose name starts with ``prefix``, in the net's order."""
    return [t.name for t in net.transitions if t.name.startswith(prefix)]
