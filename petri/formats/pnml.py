"""Read and write place/transition nets in PNML (ISO/IEC 15909-2), as the Model Checking
Contest and pm4py write them.

Reading streams the file through expat, so every element keeps its line and column: each
error names ``file:line:col``, and a big model is never held as an element tree. What is read:

- places (``<initialMarking><text>``), transitions and arcs (``<inscription><text>`` weights),
  on one page or on several (nested) pages, with ``referencePlace``/``referenceTransition``
  nodes resolved to the node they stand for;
- names: a place is called by its ``<name><text>`` when that is present and unique among the
  places, otherwise by its id; a transition by its name text, otherwise by its id. A
  transition's label is its name text when that differs from its name (for files we wrote,
  see below, the name text is the label).

Colored (symmetric or high-level) nets are refused with a message that says so.

Writing is :func:`write_pnml`'s, in petri/formats/pnml_writer.py (imported here, so that
``from petri.formats.pnml import read_pnml, write_pnml`` serves both ways).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO
from xml.parsers import expat

from diagnostics import MclError, Span
from petri.formats.pnml_writer import PNML_NS, PTNET_TYPE, TOOL, TOOL_VERSION, write_pnml
from petri.net import Net

__all__ = ["MAX_COUNT", "PNML_NS", "PTNET_TYPE", "PnmlError", "TOOL", "TOOL_VERSION",
           "read_pnml", "read_pnml_stream", "write_pnml"]

# Net types that are P/T nets (pm4py writes "pnmlcoremodel" for its nets).
_PT_TYPES = ("ptnet", "pnmlcoremodel")
# Net types and elements that only colored / high-level nets have.
_COLORED_TYPES = ("symmetricnet", "highlevelnet", "pt-hlpng", "hlpng", "coloured", "colored")
_COLORED_ELEMENTS = frozenset({"hlinitialMarking", "hlinscription", "declaration", "type"})


class PnmlError(MclError):
    """A PNML file that cannot be read as a P/T net; ``str()`` is ``file:line:col: error: ...``
    (the XML line and column; just ``file: error: ...`` for the file as a whole)."""

    def __init__(self, message: str, path: str = "", line: int | None = None,
                 col: int | None = None) -> None:
        self.message = message
        self.path = path
        self.line = line
        self.col = col
        where = path or "<pnml>"
        span = (Span.of_file(where) if line is None
                else Span(where, line, col if col is not None else 1))
        super().__init__(message, span=span, code="pnml")


# -- reading ------------------------------------------------------------------------------

@dataclass
class _Node:
    """A place, transition or reference node as found in the file."""

    kind: str  # "place" | "transition" | "referencePlace" | "referenceTransition"
    id: str
    line: int
    col: int
    name: str | None = None
    marking: str | None = None
    ref: str | None = None
    tool_name: str | None = None  # our own toolspecific copy of a transition's name


@dataclass
class _Arc:
    id: str
    source: str
    target: str
    line: int
    col: int
    weight: str | None = None


@dataclass
class _Document:
    path: str
    nets: int = 0
    net_id: str = ""
    net_name: str | None = None
    nodes: dict[str, _Node] = field(default_factory=dict)
    order: list[_Node] = field(default_factory=list)
    arcs: list[_Arc] = field(default_factory=list)


class _Reader:
    """Collects places, transitions and arcs from expat events (one pass, no element tree)."""

    def __init__(self, path: str) -> None:
        self.doc = _Document(path)
        self.parser = expat.ParserCreate(namespace_separator=" ")
        self.parser.buffer_text = True
        self.parser.StartElementHandler = self._start
        self.parser.EndElementHandler = self._end
        self.parser.CharacterDataHandler = self._text
        self.stack: list[str] = []  # local names of the open elements
        self.node: _Node | None = None
        self.arc: _Arc | None = None
        self.text: list[str] | None = None  # collecting a <text> we care about
        self.tool_depth = 0  # > 0 inside a <toolspecific> element
        self.our_tool = False

    def error(self, message: str) -> PnmlError:
        return PnmlError(message, self.doc.path, self.parser.CurrentLineNumber,
                         self.parser.CurrentColumnNumber + 1)

    def _start(self, qname: str, attrs: dict[str, str]) -> None:
        tag = qname.rsplit(" ", 1)[-1]
        parent = self.stack[-1] if self.stack else ""
        self.stack.append(tag)
        if self.tool_depth:
            self.tool_depth += 1
            if self.our_tool and tag == "name" and self.node is not None:
                self.text = []
            return
        if tag == "toolspecific":
            self.tool_depth = 1
            self.our_tool = attrs.get("tool") == TOOL and parent == "transition"
        elif tag == "net":
            self._start_net(attrs)
        elif tag in _COLORED_ELEMENTS and parent in ("place", "arc", "net"):
            raise self.error(f"<{tag}> belongs to colored nets: only P/T nets are supported "
                             "(use the model's PT version)")
        elif tag == "text" and self._wants_text(parent):
            self.text = []
        elif parent not in ("page", "net"):
            pass  # not a node, e.g. pm4py's <finalmarkings><marking><place idref=...>
        elif tag in ("place", "transition", "referencePlace", "referenceTransition"):
            self._start_node(tag, attrs)
        elif tag == "arc":
            self._start_arc(attrs)

    def _start_net(self, attrs: dict[str, str]) -> None:
        self.doc.nets += 1
        if self.doc.nets > 1:
            raise self.error("the file holds several <net>s; put one net in each file")
        net_type = attrs.get("type", "")
        short = net_type.rstrip("/").rsplit("/", 1)[-1].lower()
        if any(c in short for c in _COLORED_TYPES):
            raise self.error(f"net type {net_type!r} is a colored net: only P/T nets are "
                             "supported (use the model's PT version)")
        if not any(t in short for t in _PT_TYPES):
            raise self.error(f"net type {net_type!r} is not a P/T net "
                             f"(expected {PTNET_TYPE!r})")
        self.doc.net_id = attrs.get("id", "")

    def _start_node(self, tag: str, attrs: dict[str, str]) -> None:
        node_id = self._require(attrs, "id", tag)
        if node_id in self.doc.nodes:
            raise self.error(f"duplicate id {node_id!r}")
        line, col = self.parser.CurrentLineNumber, self.parser.CurrentColumnNumber + 1
        node = _Node(tag, node_id, line, col)
        if tag.startswith("reference"):
            node.ref = self._require(attrs, "ref", tag)
        self.doc.nodes[node_id] = node
        self.doc.order.append(node)
        self.node = node

    def _start_arc(self, attrs: dict[str, str]) -> None:
        line, col = self.parser.CurrentLineNumber, self.parser.CurrentColumnNumber + 1
        arc_id = attrs.get("id", f"arc@{line}:{col}")
        self.arc = _Arc(arc_id, self._require(attrs, "source", "arc"),
                        self._require(attrs, "target", "arc"), line, col)
        self.doc.arcs.append(self.arc)

    def _require(self, attrs: dict[str, str], key: str, tag: str) -> str:
        if key not in attrs:
            raise self.error(f"<{tag}> has no {key!r} attribute")
        return attrs[key]

    def _wants_text(self, parent: str) -> bool:
        """Is this <text> a name, marking or weight we read? (Not one in graphics etc.)"""
        if len(self.stack) < 3:
            return False
        owner = self.stack[-3]
        if parent == "name":
            return owner in ("place", "transition", "net")
        if parent == "initialMarking":
            return owner == "place"
        return parent == "inscription" and owner == "arc"

    def _text(self, data: str) -> None:
        if self.text is not None:
            self.text.append(data)

    def _end(self, qname: str) -> None:
        tag = self.stack.pop()
        if self.tool_depth:
            self.tool_depth -= 1
            if self.text is not None and tag == "name" and self.node is not None:
                self.node.tool_name = "".join(self.text).strip()
                self.text = None
            return
        if tag == "text" and self.text is not None:
            self._store_text("".join(self.text).strip())
            self.text = None
        elif tag in ("place", "transition", "referencePlace", "referenceTransition"):
            self.node = None
        elif tag == "arc":
            self.arc = None

    def _store_text(self, value: str) -> None:
        parent, owner = self.stack[-1], self.stack[-2]
        if parent == "name" and owner == "net":
            self.doc.net_name = value
        elif parent == "name" and self.node is not None:
            self.node.name = value
        elif parent == "initialMarking" and self.node is not None:
            self.node.marking = value
        elif parent == "inscription" and self.arc is not None:
            self.arc.weight = value

    def feed(self, stream: IO[bytes]) -> _Document:
        try:
            while chunk := stream.read(1 << 20):
                self.parser.Parse(chunk, False)
            self.parser.Parse(b"", True)
        except expat.ExpatError as exc:
            message = expat.ErrorString(exc.code)
            raise PnmlError(f"invalid XML: {message}", self.doc.path, exc.lineno,
                            exc.offset + 1) from None
        except LookupError as exc:  # <?xml encoding="..."?> names one Python does not know
            raise PnmlError(f"invalid XML: {exc}", self.doc.path,
                            self.parser.CurrentLineNumber, 1) from None
        if self.doc.nets == 0:
            raise PnmlError("no <net> element: not a PNML file", self.doc.path)
        return self.doc


def read_pnml(path: str | os.PathLike[str]) -> Net:
    """Read the P/T net in a PNML file; raise :class:`PnmlError` if it cannot be read."""
    path = str(path)
    try:
        with open(path, "rb") as stream:
            doc = _Reader(path).feed(stream)
    except FileNotFoundError:
        raise PnmlError("no such file", path) from None
    except IsADirectoryError:
        raise PnmlError("is a directory, not a PNML file", path) from None
    except PermissionError:
        raise PnmlError("permission denied", path) from None
    return _build(doc, Path(path).stem)


def read_pnml_stream(stream: IO[bytes], name: str) -> Net:
    """Read the P/T net in the PNML bytes of ``stream`` (an archive's member, say), named
    ``name`` in errors; raise :class:`PnmlError` if it cannot be read."""
    return _build(_Reader(name).feed(stream), Path(name).stem)


def _build(doc: _Document, fallback_name: str) -> Net:
    net = Net(doc.net_name or doc.net_id or fallback_name)
    places = [n for n in doc.order if n.kind == "place"]
    transitions = [n for n in doc.order if n.kind == "transition"]
    place_index: dict[str, int] = {}
    for node, name in zip(places, _place_names(places)):
        place_index[node.id] = net.add_place(name)
        tokens = _count(doc.path, node, node.marking, "initial marking", minimum=0)
        if tokens:
            net.initial[place_index[node.id]] = tokens
    inputs: dict[str, dict[int, int]] = {t.id: {} for t in transitions}
    outputs: dict[str, dict[int, int]] = {t.id: {} for t in transitions}
    for arc in doc.arcs:
        source, target = _resolve(doc, arc, arc.source), _resolve(doc, arc, arc.target)
        weight = _count(doc.path, arc, arc.weight, "arc weight", minimum=1)
        if source.kind == "place" and target.kind == "transition":
            arcs, place, transition = inputs, source, target
        elif source.kind == "transition" and target.kind == "place":
            arcs, place, transition = outputs, target, source
        else:
            raise PnmlError(f"arc {arc.id!r} joins {source.kind} {source.id!r} to "
                            f"{target.kind} {target.id!r}: an arc must join a place and a "
                            "transition", doc.path, arc.line, arc.col)
        p = place_index[place.id]
        arcs[transition.id][p] = arcs[transition.id].get(p, 0) + weight
    for node in transitions:
        if node.tool_name:  # written by us: the name text is the label
            name, label = node.tool_name, node.name or ""
        else:
            name = node.name or node.id
            label = node.name if node.name and node.name != name else ""
        net.add_transition(name, inputs[node.id], outputs[node.id], label=label)
    return net


def _place_names(places: list[_Node]) -> list[str]:
    """Names when present and unique, ids otherwise (and ids for all if that still clashes)."""
    texts = [p.name for p in places if p.name]
    clashing = {t for t in texts if texts.count(t) > 1} if len(set(texts)) < len(texts) else set()
    names = [p.name if p.name and p.name not in clashing else p.id for p in places]
    if len(set(names)) < len(names):  # an id equal to another place's name
        return [p.id for p in places]
    return names


def _resolve(doc: _Document, arc: _Arc, node_id: str) -> _Node:
    """The place or transition an arc end names, following reference nodes."""
    seen: set[str] = set()
    current = node_id
    for _ in range(len(doc.nodes) + 1):  # a chain of references visits each node once
        node = doc.nodes.get(current)
        if node is None:
            what = "" if current == node_id else f" (through reference {node_id!r})"
            raise PnmlError(f"dangling arc {arc.id!r}: no place or transition has id "
                            f"{current!r}{what}", doc.path, arc.line, arc.col)
        if node.ref is None:
            return node
        if current in seen:
            break
        seen.add(current)
        current = node.ref
    raise PnmlError(f"arc {arc.id!r}: reference nodes form a cycle at {node_id!r}",
                    doc.path, arc.line, arc.col)


def _count(path: str, where: _Node | _Arc, text: str | None, what: str, minimum: int) -> int:
    if text is None:
        return minimum
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < minimum:
        raise PnmlError(f"{what} of {where.id!r} must be an integer >= {minimum}, "
                        f"not {text[:40]!r}", path, where.line, where.col)
    if value > MAX_COUNT:
        raise PnmlError(f"{what} of {where.id!r} must be at most {MAX_COUNT}, not "
                        f"{text[:40]!r}", path, where.line, where.col)
    return value


MAX_COUNT = 2**31 - 1  # tokens in a place, weight of an arc: more is no net one can verify
