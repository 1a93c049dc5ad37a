"""Write a place/transition net as PNML (ISO/IEC 15909-2), for the Model Checking Contest's
tools, pm4py and our own reader (petri/formats/pnml.py, which holds the reading and the
errors).

One page is written. Its ids are the names wherever a name is a valid XML id; the place name
and the transition label (or name, if it has no label) go in ``<name><text>``, and, when a
transition has a label, its name in a ``<toolspecific tool="mcl-auv">`` element (the standard
extension point; other readers ignore it), so that reading the file back gives the same net.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from typing import IO

from petri.net import Net

PNML_NS = "http://www.pnml.org/version-2009/grammar/pnml"
PTNET_TYPE = "http://www.pnml.org/version-2009/grammar/ptnet"
TOOL = "mcl-auv"  # our <toolspecific> element, which the reader recognises
TOOL_VERSION = "0.1"
_NCNAME = re.compile(r"[A-Za-z_][\w.\-]*\Z")  # a valid XML id


def write_pnml(net: Net, path_or_file: str | os.PathLike[str] | IO[bytes]) -> None:
    """Write ``net`` with its initial marking as a PNML P/T net (one page)."""
    tree = ET.ElementTree(_net_element(net))
    ET.indent(tree, space="  ")
    if isinstance(path_or_file, (str, os.PathLike)):
        with open(path_or_file, "wb") as stream:
            tree.write(stream, encoding="utf-8", xml_declaration=True)
    else:
        tree.write(path_or_file, encoding="utf-8", xml_declaration=True)


def _net_element(net: Net) -> ET.Element:
    ET.register_namespace("", PNML_NS)

    def q(tag: str) -> str:
        return f"{{{PNML_NS}}}{tag}"

    def named(parent: ET.Element, tag: str, ident: str, name: str) -> ET.Element:
        element = ET.SubElement(parent, q(tag), id=ident)
        ET.SubElement(ET.SubElement(element, q("name")), q("text")).text = name
        return element

    ids = _Ids()
    root = ET.Element(q("pnml"))
    net_el = ET.SubElement(root, q("net"), id=ids.make(net.name or "net", "net"),
                           type=PTNET_TYPE)
    ET.SubElement(ET.SubElement(net_el, q("name")), q("text")).text = net.name
    page = ET.SubElement(net_el, q("page"), id=ids.make("page0", "page"))
    place_ids = [ids.make(p.name, "p") for p in net.places]
    for place, ident, tokens in zip(net.places, place_ids, net.initial_vector()):
        element = named(page, "place", ident, place.name)
        if tokens:
            marking = ET.SubElement(element, q("initialMarking"))
            ET.SubElement(marking, q("text")).text = str(int(tokens))
    transition_ids = [ids.make(t.name, "t") for t in net.transitions]
    for transition, ident in zip(net.transitions, transition_ids):
        element = named(page, "transition", ident, transition.label or transition.name)
        if transition.label:
            tool = ET.SubElement(element, q("toolspecific"), tool=TOOL, version=TOOL_VERSION)
            ET.SubElement(tool, q("name")).text = transition.name
    for t, transition in enumerate(net.transitions):
        for arcs, forward in ((transition.inputs, True), (transition.outputs, False)):
            for p, weight in arcs:
                ends = (place_ids[p], transition_ids[t])
                source, target = ends if forward else ends[::-1]
                arc = ET.SubElement(page, q("arc"), id=ids.make(f"a{len(ids.used)}", "a"),
                                    source=source, target=target)
                if weight != 1:
                    inscription = ET.SubElement(arc, q("inscription"))
                    ET.SubElement(inscription, q("text")).text = str(weight)
    return root


class _Ids:
    """Unique XML ids: the wanted name when it is a valid id and free, else prefix + number."""

    def __init__(self) -> None:
        self.used: set[str] = set()

    def make(self, wanted: str, prefix: str) -> str:
        if _NCNAME.match(wanted) and wanted not in self.used:
            self.used.add(wanted)
            return wanted
        # len(used) + 1 distinct candidates: at least one of them is free.
        start = len(self.used)
        for n in range(start, 2 * start + 1):
            ident = f"{prefix}{n}"
            if ident not in self.used:
                self.used.add(ident)
                return ident
        raise AssertionError("unreachable: pigeonhole")
