"""mcl/tasks_formatter.py: the canonical layout of ``mcl fmt`` for task libraries.

The layout is pinned on a small library written carelessly; then on every shipped library and
on random libraries laid out with random blanks and comments between their tokens: the
formatted text declares the same library (mcl/tasklib.py's build, spans aside), formatting it
again changes nothing, and every comment is still there, in the same order.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import MclError, Source, Span
from mcl.tasklib import build_library
from mcl.tasks_formatter import format_library_text
from tests.support import MISSIONS, REPO

COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)


def comments(text: str) -> list[str]:
    return [c.rstrip() for c in COMMENT.findall(text)]


def meaning(value: object) -> object:
    """A declaration with its spans left out: what the library means, not where it was."""
    if isinstance(value, Span):
        return None
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__name__, *(meaning(getattr(value, f.name))
                                        for f in dataclasses.fields(value)))
    if isinstance(value, dict):
        return {k: meaning(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return tuple(meaning(v) for v in value)
    return value


def same_library(a: str, b: str) -> bool:
    return meaning(build_library([Source("a.tasks", a)])) == \
        meaning(build_library([Source("a.tasks", b)]))


MESSY = """\
// the head comment
dofs   x,y ,z;// the vehicle's
behaviour   Go drives x,y events done , failed power 10 W ;
behaviour Lamp ;

behaviour Cam /* c */ power 3 W;
task Go(target:point(yaw=0 deg),tolerance:length in[0 m,10 m]=1 m,
  speed : number >= 0){start:enable Go(x=target.x,
      y = target.y,tolerance);ok:Go.done;fail:Go.done,
   Go.failed; // two
timeout:10min->fail;estimate:distance(target)/0.4m/s;stop:disable Go;

// the end of Go
}
task Now(){}
task A() { ok: Go.done;   fail: Go.failed; }
task Lamp(enable) {
    start: enable Lamp; latch: Lamp; }
"""

EXPECTED = """\
// the head comment
dofs x, y, z;  // the vehicle's
behaviour Go    drives x, y  events done, failed  power 10 W;
behaviour Lamp;

behaviour Cam /* c */ power 3 W;
task Go(target: point(yaw = 0 deg), tolerance: length in [0 m, 10 m] = 1 m,
        speed: number >= 0) {
    start:   enable Go(x = target.x,
                       y = target.y, tolerance);
    ok:      Go.done;
    fail:    Go.done,
             Go.failed;  // two
    timeout: 10 min -> fail;
    estimate: distance(target) / 0.4 m/s;
    stop:    disable Go;

    // the end of Go
}
task Now() { }
task A() { ok: Go.done; fail: Go.failed; }
task Lamp(enable) {
    start:   enable Lamp;
    latch:   Lamp;
}
"""


def test_the_canonical_layout() -> None:
    assert format_library_text(MESSY) == EXPECTED
    assert format_library_text(EXPECTED) == EXPECTED
    assert same_library(MESSY, EXPECTED)


def test_a_table_of_behaviours_ends_at_a_blank_line_a_comment_line_or_a_task() -> None:
    text = format_library_text("behaviour A events e;\nbehaviour Longer drives x;\n"
                               "// next\nbehaviour B power 1 W;\nbehaviour C drives x;\n"
                               "task T() { }\nbehaviour Dee events e;\n")
    assert text == ("behaviour A                 events e;\n"
                    "behaviour Longer  drives x;\n"
                    "// next\n"
                    "behaviour B            power 1 W;\n"
                    "behaviour C  drives x;\n"
                    "task T() { }\n"
                    "behaviour Dee  events e;\n")


def test_a_task_on_one_line_is_broken_when_too_wide_or_holding_a_comment() -> None:
    events = ", ".join(["B.e"] * 30)
    text = format_library_text(f"behaviour B events e; task T() {{ ok: {events}; }}\n")
    assert text == f"behaviour B  events e;\ntask T() {{\n    ok:      {events};\n}}\n"
    text = format_library_text("behaviour B events e; task T() { ok: B.e; /* c */ }\n")
    assert text == "behaviour B  events e;\ntask T() {\n    ok:      B.e; /* c */\n}\n"


def test_text_that_does_not_parse_is_the_loaders_error() -> None:
    with pytest.raises(MclError, match="task library: unexpected"):
        format_library_text("task T( { }\n")


SHIPPED = sorted([*(REPO / "mcl" / "tasks").glob("*.tasks"), *MISSIONS.glob("*.tasks")])


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_libraries_are_in_the_layout(path: Path) -> None:
    source = path.read_text("utf-8")
    text = format_library_text(source, str(path))
    assert text == source  # reformatted by mcl fmt: its layout
    assert same_library(text, source) and len(comments(source)) >= 2


SEPARATORS = st.sampled_from([" ", "  ", "\n", "\n\n\n", "\t", " /* c{} */ ", "// c{}\n",
                              "\n  // c{}\n", " /* c{}\n  */\n"])
DOFS = ("x", "y", "z", "yaw")
# A formal of each kind, with the ranges and defaults it may have.
KINDS: dict[str, tuple[list[list[str]], list[str] | None]] = {
    "length": ([["in", "[", "0", "m", ",", "10", "m", "]"], [">=", "0", "m"]], ["=", "1", "m"]),
    "angle": ([["<=", "180", "deg"]], ["=", "90", "deg"]),
    "duration": ([[">=", "0", "s"]], ["=", "5", "min"]),
    "number": ([[">=", "0"]], ["=", "2"]),
    "point": ([], None), "path": ([], None)}


def listed(items: list[list[str]]) -> list[str]:
    out: list[str] = []
    for i, item in enumerate(items):
        out += ([","] if i else []) + item
    return out


@st.composite
def behaviour(draw: st.DrawFn, i: int) -> tuple[list[str], list[str]]:
    """``behaviour B<i> ...;`` and its events."""
    dofs = draw(st.lists(st.sampled_from(DOFS), unique=True, max_size=3))
    events = [f"e{k}" for k in range(draw(st.integers(0, 3)))]
    tokens = ["behaviour", f"B{i}"]
    tokens += ["drives", *listed([[d] for d in dofs])] if dofs else []
    tokens += ["events", *listed([[e] for e in events])] if events else []
    tokens += ["power", str(draw(st.integers(0, 300))), "W"] if draw(st.booleans()) else []
    return tokens + [";"], events


@st.composite
def formals(draw: st.DrawFn) -> list[tuple[str, list[str]]]:
    """(kind, tokens) of a task's formals: maybe a literal word, then named parameters."""
    out: list[tuple[str, list[str]]] = []
    if draw(st.booleans()):
        out.append(("word", [draw(st.sampled_from(["enable", "disable"]))]))
    for k in range(draw(st.integers(0, 3))):
        kind = draw(st.sampled_from(sorted(KINDS)))
        ranges, default = KINDS[kind]
        tokens = [f"p{k}", ":", kind]
        if kind == "point" and draw(st.booleans()):
            tokens += ["(", "yaw", "=", "0", "deg", ")"]
        if draw(st.booleans()) and ranges:
            tokens += draw(st.sampled_from(ranges))
        if draw(st.booleans()) and default:
            tokens += default
        out.append((kind, tokens))
    return out


@st.composite
def task(draw: st.DrawFn, j: int, behaviours: list[tuple[str, list[str]]]) -> list[str]:
    """``task T<j>(...) { ... }`` whose clauses name the library's behaviours and events."""
    params = draw(formals())
    named = [(kind, tokens[0]) for kind, tokens in params if kind != "word"]
    name, events = draw(st.sampled_from(behaviours))
    bindings = [[p] if draw(st.booleans()) else [f"v{p}", "=", p] for _, p in named]
    bindings += [["x", "=", p, ".", "x"] for kind, p in named if kind == "point"]
    action = ["enable", name] + (["(", *listed(bindings), ")"] if bindings else [])
    clauses = {"start": [action], "stop": [["disable", name]]}
    if events:
        chosen = draw(st.lists(st.sampled_from(events), min_size=1, unique=True))
        clauses[draw(st.sampled_from(["ok", "fail"]))] = [[name, ".", e] for e in chosen]
    points = [p for kind, p in named if kind == "point"]
    estimates = [["2", "min"]] + [["distance", "(", p, ")", "/", "0.4", "m", "/", "s"]
                                  for p in points]
    clauses["estimate"] = [draw(st.sampled_from(estimates))]
    keep = draw(st.lists(st.sampled_from(sorted(clauses)), unique=True))
    tokens = ["task", f"T{j}", "(", *listed([t for _, t in params]), ")", "{"]
    for label in keep:
        tokens += [label, ":", *listed(clauses[label]), ";"]
    if draw(st.booleans()) and not {"ok", "fail"} & set(keep):
        tokens += ["timeout", ":", "3", "min", "->", "fail", ";"]
    return tokens + ["}"]


@st.composite
def laid_out(draw: st.DrawFn) -> tuple[str, str]:
    """A random library, written plainly, then laid out again with random blanks and
    numbered comments between its tokens; with the plain text."""
    declared = [draw(behaviour(i)) for i in range(draw(st.integers(1, 4)))]
    tokens = ["dofs", *listed([[d] for d in DOFS]), ";"] if draw(st.booleans()) else []
    for b, _ in declared:
        tokens += b
    named = [(f"B{i}", events) for i, (_, events) in enumerate(declared)]
    for j in range(draw(st.integers(1, 4))):
        tokens += draw(task(j, named))
    plain = " ".join(tokens)
    parts = [tokens[0]]
    for i, tok in enumerate(tokens[1:]):
        blank = draw(SEPARATORS).replace("{}", str(i))
        parts += [" " + blank if parts[-1] == "/" else blank, tok]  # not '///' of 'm/s'
    return plain, "".join(parts) + draw(st.sampled_from(["", "\n", "\n// the end\n"]))


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(laid_out())
def test_random_layouts_and_comments(case: tuple[str, str]) -> None:
    plain, source = case
    text = format_library_text(source)
    assert same_library(text, plain)
    assert format_library_text(text) == text
    assert comments(text) == comments(source)
    assert all(line == line.rstrip() for line in text.splitlines())  # no trailing blanks


@pytest.mark.parametrize("doc,after", [("FMT.md", "## The layout of a task library"),
                                       ("TASKS.md", "# Task libraries")])
def test_the_libraries_the_docs_show_are_in_the_layout(doc: str, after: str) -> None:
    text = (REPO / "docs" / doc).read_text("utf-8")
    block = re.search(r"```\n(.*?)```", text[text.index(after):], re.S)
    assert block is not None and "task " in block.group(1)
    assert format_library_text(block.group(1)) == block.group(1)
