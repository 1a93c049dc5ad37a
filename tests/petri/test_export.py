"""pm4py, a real and independent Petri-net library, reads what ``mclc --pnml`` writes and finds
the same places, transitions, arcs and initial marking."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.filterwarnings("ignore:the Petri net has been imported")

from mcl.api import compile_file
from tests.support import MISSIONS, cli


@pytest.fixture(scope="module")
def pm4py() -> Any:
    """pm4py, imported when this file's test runs: not at collection, where its 2.5 s of imports
    (pandas among them) were paid by every worker of make test."""
    return pytest.importorskip("pm4py")


@pytest.mark.slow
@pytest.mark.parametrize("mission", ["dam_inspection", "every_construct"])
def test_pm4py_reads_our_pnml(mission: str, tmp_path: Path, pm4py: Any) -> None:
    out = tmp_path / f"{mission}.pnml"
    proc = cli("mclc", str(MISSIONS / f"{mission}.mcl"), "--pnml", str(out), "--no-verify")
    assert proc.returncode == 0, proc.stderr
    net = compile_file(str(MISSIONS / f"{mission}.mcl")).net

    pn, initial, _final = pm4py.read_pnml(str(out))
    assert len(pn.places) == len(net.places)
    assert len(pn.transitions) == len(net.transitions)
    assert len(pn.arcs) == net.arc_count()
    # the same arcs, named by place and transition (pm4py keeps PNML names and ids)
    # pm4py names nodes by their PNML id; the file itself says which id carries which name
    names = {el.get("id"): el.findtext("{*}name/{*}text")
             for el in ET.parse(out).iter() if el.tag.endswith(("}place", "}transition"))}
    ours: Counter[tuple[str, str, str, int]] = Counter()
    for t in net.transitions:
        for p, w in t.inputs:
            ours[(net.places[p].name, t.label or t.name, "in", w)] += 1
        for p, w in t.outputs:
            ours[(net.places[p].name, t.label or t.name, "out", w)] += 1
    theirs: Counter[tuple[str, str, str, int]] = Counter()
    for arc in pn.arcs:
        if isinstance(arc.source, pm4py.objects.petri_net.obj.PetriNet.Place):
            theirs[(names[arc.source.name], arc.target.label, "in", arc.weight)] += 1
        else:
            theirs[(names[arc.target.name], arc.source.label, "out", arc.weight)] += 1
    assert ours == theirs
    marked = {names[p.name]: n for p, n in initial.items()}
    assert marked == {net.places[p].name: n for p, n in net.initial.items() if n}
