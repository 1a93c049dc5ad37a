"""petri/formats/graphml.py, and ``mclc --graphml``: the reachability graph as GraphML, read
back with networkx; refused on one line (exit 2) where the route took no explicit graph."""

from __future__ import annotations

import io
import json
from pathlib import Path

import networkx as nx
import pytest

from diagnostics import Source
from mcl.api import compile_source
from petri.formats.graphml import GraphTooLarge, write_graphml
from petri.verification import reachability as rg
from tests.support import cli, write

MISSION = "MISSION { TRY { Wait(1 s) } CATCH { Alarms() } DO { Surface() } }"


def test_graphml_reads_back_as_the_same_graph(tmp_path: Path) -> None:
    net = compile_source(Source("m.mcl", MISSION)).net
    ss = rg.explore(net)
    write_graphml(net, ss, tmp_path / "g.graphml")
    back = nx.read_graphml(tmp_path / "g.graphml")  # node ids come back as strings
    assert back.is_directed() and back.is_multigraph()
    assert back.number_of_nodes() == ss.n_markings and back.number_of_edges() == ss.n_arcs
    assert (back.graph["net"], back.graph["complete"]) == (net.name, True)
    arcs = sorted((str(s), str(d), int(t)) for s, d, t in zip(ss.src, ss.dst, ss.transition))
    assert sorted((s, d, data["transition"]) for s, d, data in back.edges(data=True)) == arcs
    for _, _, data in back.edges(data=True):
        assert data["name"] == net.transitions[data["transition"]].name
    assert back.nodes["0"] == {"marking": net.describe_marking(ss.markings[0]),
                               "initial": True, "end": ""}
    assert {data["end"] for _, data in back.nodes(data=True)} == {"", "ok", "fail"}


def test_graphml_to_a_binary_file_and_its_limit() -> None:
    net = compile_source(Source("m.mcl", MISSION)).net
    ss = rg.explore(net)
    buffer = io.BytesIO()
    write_graphml(net, ss, buffer)
    assert buffer.getvalue().startswith(b"<?xml") and b"<graphml" in buffer.getvalue()
    with pytest.raises(GraphTooLarge, match=f"{ss.n_arcs:,} arcs, more than the 10 "):
        write_graphml(net, ss, io.BytesIO(), max_arcs=10)


# -- mclc --graphml ---------------------------------------------------------------------------

@pytest.mark.slow
def test_mclc_writes_the_graph_it_verified(tmp_path: Path) -> None:
    mission = write(tmp_path, MISSION)
    out = tmp_path / "g.graphml"
    proc = cli("mclc", str(mission), "--graphml", str(out), "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)["verification"]
    graph = nx.read_graphml(out)
    assert graph.number_of_nodes() == report["reachable_markings"]
    assert graph.number_of_edges() == report["reachability_arcs"]
    text = cli("mclc", str(mission), "--graphml", str(out))
    assert f"  wrote reachability graph to {out}\n" in text.stdout


@pytest.mark.slow
def test_mclc_writes_the_graph_of_a_pnml_net(tmp_path: Path) -> None:
    net = compile_source(Source("m.mcl", MISSION)).net
    pnml = tmp_path / "m.pnml"
    assert cli("mclc", str(write(tmp_path, MISSION)), "--no-verify", "--pnml",
               str(pnml)).returncode == 0
    out = tmp_path / "p.graphml"
    proc = cli("mclc", str(pnml), "--graphml", str(out))
    assert proc.returncode == 0, proc.stderr
    assert f"wrote reachability graph to {out}" in proc.stdout
    graph = nx.read_graphml(out)
    assert graph.number_of_nodes() == rg.explore(net).n_markings


@pytest.mark.slow
@pytest.mark.parametrize("options, why", [
    (["--method", "structural"], "the structural route explores none: use --method explicit"),
    (["--no-verify"], "--no-verify explores none: use --method explicit"),
    (["--max-markings", "10"],  # auto: the estimate is over the limit, it goes structural
     "--method auto took the structural route, which explores no reachability graph; "
     "--method explicit gives one"),
])
def test_mclc_refuses_a_graph_the_route_did_not_build(tmp_path: Path, options: list[str],
                                                      why: str) -> None:
    out = tmp_path / "g.graphml"
    proc = cli("mclc", str(write(tmp_path, MISSION)), "--graphml", str(out), *options)
    assert proc.returncode == 2
    assert len(proc.stderr.splitlines()) == 1 and why in proc.stderr
    assert "Traceback" not in proc.stderr and not out.exists()


def test_mclc_refuses_an_unwritable_graph_file_before_any_work(tmp_path: Path) -> None:
    mission = write(tmp_path, MISSION)
    proc = cli("mclc", str(mission), "--graphml", str(tmp_path / "no" / "g.graphml"))
    assert proc.returncode == 2 and "cannot write it (--graphml)" in proc.stderr
    proc = cli("mclc", str(mission), str(mission), "--graphml", str(tmp_path / "g.graphml"))
    assert proc.returncode == 2 and "take one input file" in proc.stderr
