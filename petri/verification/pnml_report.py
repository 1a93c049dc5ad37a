"""The state-space report of a P/T net: how many markings and arcs, bounds, deadlocks, dead
transitions, 1-safety. It picks the explicit search when the state space fits and the symbolic
(BDD) one otherwise.

Command line (``app/pnml_report.py``)::

    python -m app.pnml_report MODEL.pnml|MODEL.tgz [--json] [--method auto|explicit|symbolic]

A ``.tgz`` is a Model Checking Contest archive; its ``*/model.pnml`` is read. The text of the
report is :mod:`app.reports.pnml`'s.
"""

from __future__ import annotations

import stat
import time
from pathlib import Path
from typing import Any

from petri.verification import reachability as rg
from petri.verification import symbolic
from petri.net import Net
from petri.formats.mcc_archive import read_archive
from petri.formats.pnml import PnmlError, read_pnml

# In "auto", a net that may be 1-safe is first explored explicitly up to EXPLICIT_PROBE
# markings. If that does not finish, the symbolic search takes over for at most
# SYMBOLIC_SECONDS; if it runs out of time, or the net turns out not to be 1-safe, the explicit
# search goes on up to max_markings. (On the contest models, a 1-safe net with more markings
# than the probe is decided faster symbolically; nets whose BDDs blow up, like BART-PT-002 or
# TokenRing-PT-010, have small state spaces that the probe finishes.)
EXPLICIT_PROBE = 500_000
SYMBOLIC_SECONDS = 60.0
# The memory the explicit search may use (``mclc --max-memory``): the markings it may keep are
# estimated before it starts (petri/verification/reachability.py's markings_within) and the
# search stops there, incomplete, rather than run out of memory. 1 GiB by default.
MAX_BYTES = 1 << 30

Report = dict[str, Any]


def analyse(net: Net, method: str = "auto", max_markings: int = 20_000_000,
            max_tokens: int = 255, probe: int = EXPLICIT_PROBE,
            symbolic_seconds: float = SYMBOLIC_SECONDS, max_bytes: float = MAX_BYTES
            ) -> Report:
    """Answer the contest's state-space questions about ``net``.

    Keys: net, places, transitions, markings, arcs, max_tokens, deadlock_reachable,
    dead_transitions (names), one_safe, complete, method ("explicit"/"symbolic"), seconds,
    and, when a limit stopped the search, stop_reason and unbounded_place. Answers that an
    incomplete search cannot give are None.

    The explicit search keeps at most the markings that fit ``max_bytes`` (estimated before
    it starts); past them it stops, incomplete, with a ``stop_reason`` that names the budget.
    A MemoryError nevertheless (the symbolic search's BDDs, say) ends the analysis
    incomplete too, with ``stop_reason`` "out of memory": it never reaches the caller.

    ``method="symbolic"`` raises :class:`petri.verification.symbolic.NotOneSafe` for a net that is not
    1-safe and :class:`petri.verification.symbolic.SymbolicLimit` after ``symbolic_seconds``.
    """
    return analyse_graph(net, method, max_markings, max_tokens, probe, symbolic_seconds,
                         arcs=False, max_bytes=max_bytes)[0]


def analyse_graph(net: Net, method: str = "auto", max_markings: int = 20_000_000,
                  max_tokens: int = 255, probe: int = EXPLICIT_PROBE,
                  symbolic_seconds: float = SYMBOLIC_SECONDS, arcs: bool = True,
                  max_bytes: float = MAX_BYTES) -> tuple[Report, rg.StateSpace | None]:
    """:func:`analyse`'s report and the explicit reachability graph it was made from, with
    its arcs (``arcs=True``) for :func:`petri.verification.reachability.as_digraph`; None
    when the symbolic search made the report."""
    if method not in ("auto", "explicit", "symbolic"):
        raise ValueError(f"unknown method {method!r}")
    start = time.perf_counter()
    space: rg.StateSpace | None = None
    room = rg.markings_within(net, max_bytes, max_tokens, arcs)
    budget = f"the memory budget of {max_bytes / 2**20:,.0f} MiB"
    try:
        if method == "symbolic":
            report = symbolic_report(net, symbolic.explore(net, time_limit=symbolic_seconds,
                                                           max_bytes=max_bytes))
        elif room < 1:
            report = unexplored_report(net, f"no room for markings in {budget}")
        elif method == "explicit":
            space = rg.explore(net, min(max_markings, room), max_tokens, arcs=arcs,
                               max_bytes=max_bytes)
            report = explicit_report(net, space)
        else:
            report, space = _auto(net, min(max_markings, room), max_tokens, probe,
                                  symbolic_seconds, arcs, max_bytes)
    except MemoryError:
        space, report = None, unexplored_report(net, f"out of memory (within {budget})")
    if space is not None and not space.complete and room < max_markings and \
            space.n_markings >= room:
        report["stop_reason"] = f"more than {room:,} markings: {budget}"
    report["seconds"] = round(time.perf_counter() - start, 3)
    return report, space


def unexplored_report(net: Net, why: str) -> Report:
    """The report of a net whose search could not run or finish: nothing known."""
    report = _header(net)
    report.update(markings=None, arcs=None, max_tokens=None, deadlock_reachable=None,
                  dead_transitions=None, one_safe=None, complete=False, method="explicit",
                  stop_reason=why, unbounded_place=None)
    return report


def _auto(net: Net, max_markings: int, max_tokens: int, probe: int,
          symbolic_seconds: float, arcs: bool, max_bytes: float
          ) -> tuple[Report, rg.StateSpace | None]:
    if symbolic.is_candidate(net) and symbolic.available():  # dd's import only if it may serve
        ss = rg.explore(net, max_markings=min(probe, max_markings), max_tokens=max_tokens,
                        arcs=arcs, max_bytes=max_bytes)
        if ss.complete:
            return explicit_report(net, ss), ss
        if rg.max_tokens(ss) <= 1:
            try:
                result = symbolic.explore(net, time_limit=symbolic_seconds,
                                          max_bytes=max_bytes)
                return symbolic_report(net, result), None
            except (symbolic.NotOneSafe, symbolic.SymbolicLimit):
                pass  # explicit after all
        if probe >= max_markings:
            return explicit_report(net, ss), ss
    ss = rg.explore(net, max_markings, max_tokens, arcs=arcs, max_bytes=max_bytes)
    return explicit_report(net, ss), ss


def _header(net: Net) -> Report:
    return {"net": net.name, "places": len(net.places), "transitions": len(net.transitions)}


def explicit_report(net: Net, ss: rg.StateSpace) -> Report:
    report = _header(net)
    dead = rg.deadlocks(ss)
    bound = rg.max_tokens(ss)
    report.update(
        markings=ss.n_markings,
        arcs=ss.n_arcs,
        max_tokens=bound if ss.complete else None,
        deadlock_reachable=bool(dead.size) if ss.complete else (True if dead.size else None),
        dead_transitions=([net.transitions[t].name for t in rg.dead_transitions(net, ss)]
                          if ss.complete else None),
        one_safe=bound <= 1 if ss.complete else (False if bound > 1 else None),
        complete=ss.complete,
        method="explicit",
    )
    if not ss.complete:
        report["stop_reason"] = ss.stop_reason
        report["unbounded_place"] = (None if ss.unbounded_place is None
                                     else net.places[ss.unbounded_place].name)
        if ss.unbounded_place is not None:
            report["one_safe"] = False
    return report


def symbolic_report(net: Net, result: Any) -> Report:
    report = _header(net)
    report.update(
        markings=result.markings,
        arcs=result.arcs,
        max_tokens=result.max_tokens,
        deadlock_reachable=result.deadlock_reachable,
        dead_transitions=[net.transitions[t].name for t in result.dead_transitions],
        one_safe=result.one_safe,
        complete=True,
        method="symbolic",
        bdd_nodes=result.bdd_nodes,
    )
    return report


def load_net(path: str | Path) -> Net:
    """Read a PNML file, or the ``model.pnml`` inside a contest ``.tgz`` archive (read in
    place, never extracted; an archive with an entry that is not a plain file or folder
    inside its folder is refused: petri/formats/mcc_archive.py)."""
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise PnmlError("no such file", str(path)) from None
    except OSError as exc:
        raise PnmlError(f"cannot be read: {exc.strerror}", str(path)) from None
    if not stat.S_ISREG(mode):  # a FIFO or a device would be read for ever: never opened
        kind = "a directory" if stat.S_ISDIR(mode) else "not a regular file (a FIFO or a device)"
        raise PnmlError(f"is {kind}: not a PNML file nor a contest archive", str(path))
    if path.suffix not in (".tgz", ".gz"):
        return read_pnml(path)
    return read_archive(path)
