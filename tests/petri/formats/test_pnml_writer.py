"""The PNML writer (petri/formats/pnml_writer.py) on its own: the XML ids it makes, where a
transition's name and label go, which arcs carry an inscription. The round trips through our
reader and pm4py are tests/petri/formats/test_pnml.py's."""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET

from petri.formats.pnml_writer import PNML_NS, TOOL, write_pnml
from petri.net import Net

Q = f"{{{PNML_NS}}}"


def written(net: Net) -> ET.Element:
    buffer = io.BytesIO()
    write_pnml(net, buffer)
    return ET.fromstring(buffer.getvalue())


def nodes(root: ET.Element, tag: str) -> dict[str, ET.Element]:
    """The page's elements of ``tag``, by the text of their ``<name>``."""
    return {e.findtext(f"{Q}name/{Q}text") or "": e for e in root.iter(f"{Q}{tag}")}


def test_ids_are_the_names_when_they_can_be_and_always_unique() -> None:
    net = Net("ids")
    a = net.add_place("a")
    odd = net.add_place("9 not an id")
    net.add_place("p0")  # the id a numbered place would take first
    net.add_transition("a", [a], [odd])  # the same name as a place
    net.add_transition("t", [odd], [a])
    root = written(net)
    ids = [e.get("id") for e in root.iter() if e.get("id") is not None]
    assert len(ids) == len(set(ids)), ids
    places, transitions = nodes(root, "place"), nodes(root, "transition")
    assert places["a"].get("id") == "a" and places["p0"].get("id") == "p0"
    assert transitions["t"].get("id") == "t"
    odd_id, clashing_id = places["9 not an id"].get("id"), transitions["a"].get("id")
    assert odd_id is not None and odd_id.startswith("p") and odd_id != "p0"
    assert clashing_id is not None and clashing_id.startswith("t") and clashing_id != "a"


def test_a_labelled_transition_keeps_its_name_in_our_toolspecific_element() -> None:
    net = Net("labels")
    p = net.add_place("p")
    net.add_transition("GoTo@3:1.start", [p], [p], label="start GoTo")
    net.add_transition("plain", [p], [p])
    transitions = nodes(written(net), "transition")
    assert set(transitions) == {"start GoTo", "plain"}  # the label is the name text
    tool = transitions["start GoTo"].find(f"{Q}toolspecific")
    assert tool is not None and tool.get("tool") == TOOL
    assert tool.findtext(f"{Q}name") == "GoTo@3:1.start"
    assert transitions["plain"].find(f"{Q}toolspecific") is None


def test_only_weights_other_than_one_and_markings_other_than_zero_are_written() -> None:
    net = Net("weights")
    src, dst = net.add_place("src"), net.add_place("dst")
    net.initial = {src: 3}
    net.add_transition("t", {src: 2}, {dst: 1})
    root = written(net)
    places = nodes(root, "place")
    assert places["src"].findtext(f"{Q}initialMarking/{Q}text") == "3"
    assert places["dst"].find(f"{Q}initialMarking") is None
    weights = {(arc.get("source"), arc.get("target")): arc.findtext(f"{Q}inscription/{Q}text")
               for arc in root.iter(f"{Q}arc")}
    assert weights == {("src", "t"): "2", ("t", "dst"): None}
