"""GraphML of a net's reachability graph: one node per reachable marking, one edge per firing.

GraphML is the XML graph format that networkx, yEd, Gephi and Cytoscape read. The graph is
:func:`petri.verification.reachability.as_digraph`'s, written by networkx's ``write_graphml``;
its attributes (``marking``, ``initial``, ``end`` on nodes; ``transition``, ``name``,
``label``, ``line`` on edges) are declared as GraphML keys. ``mclc MISSION.mcl --graphml FILE``
writes the graph the explicit route verified.
"""

from __future__ import annotations

from pathlib import Path
from typing import IO

from diagnostics import MclError
from petri.net import Net
from petri.verification.reachability import StateSpace, as_digraph

# networkx holds about 600 bytes an arc (and writes about 130): past this many arcs a graph
# is refused rather than filling the memory; pass max_arcs=None to write it all the same.
MAX_ARCS = 2_000_000


class GraphTooLarge(MclError, ValueError):
    """The reachability graph has more arcs than the limit given to :func:`write_graphml`
    (what to do: a smaller net, or a larger ``max_arcs``)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, code="graph-too-large", text=message)


def write_graphml(net: Net, ss: StateSpace, target: str | Path | IO[bytes],
                  max_arcs: int | None = MAX_ARCS) -> None:
    """Write the reachability graph ``ss`` of ``net`` as GraphML to a path or binary file."""
    import networkx as nx  # lazily: importing networkx costs start-up time most runs never use

    if max_arcs is not None and ss.n_arcs > max_arcs:
        raise GraphTooLarge(f"the reachability graph has {ss.n_arcs:,} arcs, more than the "
                            f"{max_arcs:,} a GraphML export holds in memory")
    nx.write_graphml(as_digraph(net, ss), target)
