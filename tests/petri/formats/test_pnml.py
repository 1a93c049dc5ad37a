"""PNML reading and writing: round trips, pm4py reading what we write (and we reading what
pm4py writes), the Model Checking Contest's conventions, and clear errors for bad files."""

from __future__ import annotations

import io
import json
import subprocess
import sys
import tarfile
from collections import Counter
from pathlib import Path

import pytest

from petri.net import Net
from tests.support import REPO, SHARED
from petri.formats.pnml import PnmlError, read_pnml, write_pnml

pytestmark = pytest.mark.filterwarnings("ignore:the Petri net has been imported")

MCC = SHARED / "mcc"
NS = 'xmlns="http://www.pnml.org/version-2009/grammar/pnml"'
PT = 'type="http://www.pnml.org/version-2009/grammar/ptnet"'


def sample_net() -> Net:
    """Weights, labels, a repeated transition name, odd characters, an empty place."""
    net = Net("sample net")
    idle = net.add_place("idle")
    busy = net.add_place("busy <&> \"quoted\"")
    pool = net.add_place("pool")
    net.add_place("never used")
    net.add_place("t_start")  # the same text as a transition name
    net.initial = {idle: 1, pool: 3}
    net.add_transition("t_start", {idle: 1, pool: 2}, {busy: 1}, label="start the job")
    net.add_transition("t_stop", {busy: 1}, {idle: 1, pool: 2})
    net.add_transition("t_stop", [busy], [busy])  # a second transition of the same name
    net.add_transition("9 bad id", [], [pool], label="9 bad id")
    return net


def structure(net: Net) -> tuple[object, ...]:
    places = [p.name for p in net.places]
    transitions = [(t.name, t.label,
                    sorted((places[p], w) for p, w in t.inputs),
                    sorted((places[p], w) for p, w in t.outputs)) for t in net.transitions]
    marking = {places[p]: n for p, n in net.initial.items() if n}
    return places, transitions, marking


def write_text(tmp_path: Path, text: str, name: str = "net.pnml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# -- round trips --------------------------------------------------------------------------

def test_round_trip_keeps_places_transitions_arcs_marking(tmp_path: Path) -> None:
    net = sample_net()
    write_pnml(net, tmp_path / "out.pnml")
    back = read_pnml(tmp_path / "out.pnml")
    assert back.name == net.name
    assert structure(back) == structure(net)


def test_round_trip_through_a_file_object(tmp_path: Path) -> None:
    net = sample_net()
    buffer = io.BytesIO()
    write_pnml(net, buffer)
    assert buffer.getvalue().startswith(b"<?xml version='1.0' encoding='utf-8'?>")
    (tmp_path / "out.pnml").write_bytes(buffer.getvalue())
    assert structure(read_pnml(tmp_path / "out.pnml")) == structure(net)


def test_round_trip_of_a_contest_model(tmp_path: Path) -> None:
    if not MCC.is_dir():
        pytest.skip(f"{MCC} is absent: the contest models are not available")
    with tarfile.open(MCC / "models" / "DrinkVendingMachine-PT-02.tgz") as archive:
        archive.extractall(tmp_path, filter="data")
    net = read_pnml(tmp_path / "DrinkVendingMachine-PT-02" / "model.pnml")
    assert (len(net.places), len(net.transitions), net.arc_count()) == (24, 72, 440)
    assert max(w for t in net.transitions for _, w in t.inputs + t.outputs) == 3
    write_pnml(net, tmp_path / "again.pnml")
    assert structure(read_pnml(tmp_path / "again.pnml")) == structure(net)


# -- pm4py, an independent reader and writer ----------------------------------------------

def test_pm4py_reads_what_we_write(tmp_path: Path) -> None:
    pm4py = pytest.importorskip("pm4py")
    from pm4py.objects.petri_net.obj import PetriNet

    net = sample_net()
    write_pnml(net, tmp_path / "out.pnml")
    pn, initial, _final = pm4py.read_pnml(str(tmp_path / "out.pnml"))
    place_name = {p: p.properties["place_name_tag"] for p in pn.places}
    assert sorted(place_name.values()) == sorted(p.name for p in net.places)
    assert Counter(t.label for t in pn.transitions) == Counter(
        t.label or t.name for t in net.transitions)
    ours = Counter()
    for t in net.transitions:
        for p, w in t.inputs:
            ours[(net.places[p].name, t.label or t.name, "in", w)] += 1
        for p, w in t.outputs:
            ours[(net.places[p].name, t.label or t.name, "out", w)] += 1
    theirs = Counter()
    for arc in pn.arcs:
        if isinstance(arc.source, PetriNet.Place):
            theirs[(place_name[arc.source], arc.target.label, "in", arc.weight)] += 1
        else:
            theirs[(place_name[arc.target], arc.source.label, "out", arc.weight)] += 1
    assert ours == theirs
    assert {place_name[p]: n for p, n in initial.items()} == {"idle": 1, "pool": 3}


def test_we_read_what_pm4py_writes(tmp_path: Path) -> None:
    pm4py = pytest.importorskip("pm4py")
    from pm4py.objects.petri_net.obj import Marking, PetriNet
    from pm4py.objects.petri_net.utils.petri_utils import add_arc_from_to

    pn = PetriNet("from pm4py")
    source, sink = PetriNet.Place("source"), PetriNet.Place("sink")
    register = PetriNet.Transition("t1", "register request")
    silent = PetriNet.Transition("t2", None)  # pm4py writes an invisible transition
    for node in (source, sink):
        pn.places.add(node)
    for node in (register, silent):
        pn.transitions.add(node)
    add_arc_from_to(source, register, pn, weight=2)
    add_arc_from_to(register, sink, pn)
    add_arc_from_to(sink, silent, pn)
    pm4py.write_pnml(pn, Marking({source: 2}), Marking({sink: 1}), str(tmp_path / "pm.pnml"))

    net = read_pnml(tmp_path / "pm.pnml")
    places, transitions, marking = structure(net)
    assert sorted(places) == ["sink", "source"]
    assert marking == {"source": 2}
    by_label = {t[1] or t[0]: t for t in transitions}
    assert by_label["register request"][2:] == ([("source", 2)], [("sink", 1)])
    assert len(transitions) == 2


# -- the contest's conventions ------------------------------------------------------------

def test_pages_references_weights_and_names(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"""<?xml version="1.0"?>
<pnml {NS}><net id="n" {PT}><name><text>paged</text></name>
  <page id="pg1"><name><text>not a node name</text></name>
    <place id="p1"><name><graphics><offset x="1" y="2"/></graphics><text>ready</text></name>
      <initialMarking><text> 2 </text></initialMarking></place>
    <transition id="t1"><name><text>go</text></name></transition>
    <page id="pg2">
      <place id="p2"/>
      <referencePlace id="rp1" ref="p1"/>
      <arc id="a2" source="t1" target="p2"><inscription><text>3</text></inscription></arc>
    </page>
  </page>
  <page id="pg3">
    <referenceTransition id="rt1" ref="t1"/>
    <arc id="a1" source="rp1" target="rt1"><inscription><text>2</text></inscription></arc>
  </page>
</net></pnml>""")
    net = read_pnml(path)
    assert net.name == "paged"
    assert structure(net) == (["ready", "p2"], [("go", "", [("ready", 2)], [("p2", 3)])],
                              {"ready": 2})


def test_ids_name_places_whose_names_collide_or_are_missing(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"""<pnml {NS}><net id="n" {PT}><page id="g">
  <place id="a"><name><text>same</text></name></place>
  <place id="b"><name><text>same</text></name></place>
  <place id="c"/>
  <place id="d"><name><text>unique</text></name></place>
</page></net></pnml>""")
    assert [p.name for p in read_pnml(path).places] == ["a", "b", "c", "unique"]


# -- errors -------------------------------------------------------------------------------

def error_of(path: Path) -> PnmlError:
    with pytest.raises(PnmlError) as info:
        read_pnml(path)
    return info.value


def test_missing_file(tmp_path: Path) -> None:
    err = error_of(tmp_path / "absent.pnml")
    assert str(err) == f"{tmp_path / 'absent.pnml'}: error: no such file"


def test_invalid_xml_gives_line_and_column(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"<pnml {NS}>\n  <net id='n' {PT}>\n    <place id='p'>\n"
                                "  </net>\n</pnml>\n")
    err = error_of(path)
    assert (err.line, err.col) == (4, 5)
    assert str(err) == f"{path}:4:5: error: invalid XML: mismatched tag"


def test_empty_file(tmp_path: Path) -> None:
    err = error_of(write_text(tmp_path, ""))
    assert "invalid XML: no element found" in str(err)


def test_colored_nets_are_refused_as_such(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"""<pnml {NS}>
<net id="n" type="http://www.pnml.org/version-2009/grammar/symmetricnet"><page id="g"/></net>
</pnml>""")
    err = error_of(path)
    assert err.line == 2
    assert "colored net" in err.message and "only P/T nets" in err.message


def test_colored_elements_in_a_pt_net_are_refused(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"""<pnml {NS}><net id="n" {PT}><page id="g">
<place id="p"><type><text>Dot</text></type></place></page></net></pnml>""")
    assert "belongs to colored nets" in error_of(path).message


def test_dangling_arc_names_the_arc_and_where_it_is(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"""<pnml {NS}><net id="n" {PT}><page id="g">
<place id="p"/>
<transition id="t"/>
<arc id="a7" source="p" target="nowhere"/>
</page></net></pnml>""")
    err = error_of(path)
    assert (err.line, err.col) == (4, 1)
    assert err.message == "dangling arc 'a7': no place or transition has id 'nowhere'"


def test_arc_between_two_places(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"""<pnml {NS}><net id="n" {PT}><page id="g">
<place id="p"/><place id="q"/><arc id="a" source="p" target="q"/></page></net></pnml>""")
    assert "an arc must join a place and a transition" in error_of(path).message


@pytest.mark.parametrize(("snippet", "message"), [
    ('<place id="p"><initialMarking><text>two</text></initialMarking></place>',
     "initial marking of 'p' must be an integer >= 0, not 'two'"),
    ('<place id="p"/><transition id="t"/><arc id="a" source="p" target="t">'  # noqa: ISC004
     '<inscription><text>0</text></inscription></arc>',
     "arc weight of 'a' must be an integer >= 1, not '0'"),
    ('<place id="p"/><place id="p"/>', "duplicate id 'p'"),
    ('<place/>', "<place> has no 'id' attribute"),
])
def test_bad_values(tmp_path: Path, snippet: str, message: str) -> None:
    path = write_text(tmp_path, f'<pnml {NS}><net id="n" {PT}><page id="g">{snippet}'
                                "</page></net></pnml>")
    assert error_of(path).message == message


def test_not_pnml_at_all(tmp_path: Path) -> None:
    assert error_of(write_text(tmp_path, "<html><body/></html>")).message == \
        "no <net> element: not a PNML file"


def test_several_nets(tmp_path: Path) -> None:
    path = write_text(tmp_path, f'<pnml {NS}><net id="a" {PT}/><net id="b" {PT}/></pnml>')
    assert "several <net>s" in error_of(path).message


# -- the command line ---------------------------------------------------------------------

def run_report(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "app.pnml_report", *args],
                          capture_output=True, text=True, timeout=300, check=False,
                          cwd=REPO, stdin=subprocess.DEVNULL)


def test_cli_reports_a_bad_file_with_its_position(tmp_path: Path) -> None:
    path = write_text(tmp_path, f"<pnml {NS}>\n<net id='n' {PT}>\n<page id='p'>\n</net>")
    proc = run_report(str(path))
    assert proc.returncode == 2  # invalid input (docs/EXIT.md), as mclc FILE.pnml says it
    assert proc.stderr.strip() == f"{path}:4:3: error: invalid XML: mismatched tag"
    assert proc.stdout == ""


@pytest.mark.slow
def test_cli_text_and_json(tmp_path: Path) -> None:
    net = sample_net()  # its source transition '9 bad id' fills 'pool' forever
    write_pnml(net, tmp_path / "unbounded.pnml")
    text = run_report(str(tmp_path / "unbounded.pnml"))
    assert text.returncode == 0, text.stderr
    assert "complete            no" in text.stdout
    assert "unbounded place     pool" in text.stdout

    net.transitions.pop()
    write_pnml(net, tmp_path / "net.pnml")
    proc = run_report(str(tmp_path / "net.pnml"), "--json", "--method", "explicit")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["net"] == "sample net" and report["complete"] is True
    assert report["method"] == "explicit"
    assert report["markings"] == len(report_markings(net))


def report_markings(net: Net) -> set[tuple[int, ...]]:
    """The reachable markings by a plain Python search (an independent count)."""
    start = tuple(int(x) for x in net.initial_vector())
    seen, todo = {start}, [start]
    for _ in range(10_000):  # the sample net has a handful of markings
        if not todo:
            break
        m = todo.pop()
        for t, tr in enumerate(net.transitions):
            if all(m[p] >= w for p, w in tr.inputs):
                effect = net.effect(t)
                nxt = tuple(int(m[p] + effect.get(p, 0)) for p in range(len(m)))
                if max(nxt) <= 50 and nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
    return seen
