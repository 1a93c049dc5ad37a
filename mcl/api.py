"""The pipeline behind a tiny facade: file -> AST -> checked -> Petri net."""

from __future__ import annotations

import os
from pathlib import Path
from dataclasses import dataclass

from diagnostics import Diagnostic, MclError, Source, read_source
from petri.net import Net

from mcl import ast, checker, compiler, parser, tasklib


@dataclass
class Compiled:
    """A compiled mission: its syntax tree, the checked mission, its net and its source."""

    mission: ast.Mission
    checked: checker.Checked
    net: Net
    source: Source

    @property
    def name(self) -> str:
        """The mission's name in every command: its MISSION's name if it has one, else the
        stem of its file (``missions/dam_inspection.mcl`` -> ``dam_inspection``)."""
        return self.mission.name or Path(self.source.name).stem

    @property
    def warnings(self) -> list[Diagnostic]:
        return self.checked.diagnostics


def parse_params(assignments: list[str], files: list[str] | None = None
                 ) -> dict[str, tuple[ast.Value, Source]]:
    """``name=value`` strings (command line) and parameter files (lines ``name = value``,
    ``//`` comments) into values, each with the source it came from for messages."""
    out: dict[str, tuple[ast.Value, Source]] = {}
    for path in files or []:
        src = read_source(path)
        for number, line in enumerate(src.lines, start=1):
            text = line.split("//", 1)[0].strip().rstrip(";")
            if not text:
                continue
            name, eq, value = text.partition("=")
            if not eq or not name.strip().isidentifier():
                raise MclError(src.diagnostic(
                    "error", "expected 'name = value'", src.span(number, 1),
                    "a parameter file has one 'name = value' per line", "bad-param-file"))
            col = line.index("=") + 2
            try:  # spans of the value are its place in the file
                out[name.strip()] = (parser.parse_value(value, src.name, number, col), src)
            except MclError:
                raise MclError(src.diagnostic(
                    "error", f"not a value: {value.strip()!r}", src.span(number, col),
                    "values are numbers with an optional unit, lists, points or names",
                    "bad-value")) from None
    for item in assignments:
        name, eq, value = item.partition("=")
        origin = Source(f"--param {item}", item)
        if not eq or not name.strip().isidentifier():
            raise MclError(origin.diagnostic(
                "error", f"expected --param NAME=VALUE, got {item!r}", origin.span(1, 1),
                "e.g. --param h=90deg or --param 'initialPos=(0, -8, 2, 90)'", "bad-param"))
        parsed = parser.parse_value(value, origin.name, column=len(name) + 2)
        names = [n for n in _names_in(parsed) if n not in ast.WORDS]
        if names:
            raise MclError(origin.diagnostic(
                "error", f"--param {item}: '{names[0]}' is not a value", origin.span(1, 1),
                "a value is a number (with a unit), a list [a, b] or a point (x, y, z, yaw)",
                "bad-param"))
        out[name.strip()] = (parsed, origin)
    return out


def _names_in(value: ast.Value) -> list[str]:
    match value:
        case ast.Ref(name=n):
            return [n]
        case ast.ListValue(items=items) | ast.Point(items=items):
            return [n for i in items for n in _names_in(i)]
    return []


def library_of(mission: ast.Mission, source: Source) -> tasklib.Library:
    """The task libraries a parsed mission is written against: core, then those its USES
    name (relative to its file; default the Ictineu library)."""
    return tasklib.load(_uses(mission, source))


def _uses(mission: ast.Mission, source: Source) -> list[str] | None:
    """The libraries named by USES, relative to the mission file (shipped ones by name)."""
    paths = []
    for use in mission.uses:
        if tasklib.is_shipped(use.library):
            paths.append(use.library)
            continue
        path = os.path.join(os.path.dirname(source.name), use.library)
        why = tasklib.not_a_library(path)
        if why is not None:  # never read, nor quoted: any file
            raise MclError(source.diagnostic(
                "error", f"{use.library!r} is not a task library: {why}",
                use.span, f"shipped libraries: {', '.join(tasklib.SHIPPED)}; other paths are "
                "relative to the mission file", "not-a-library"))
        if not os.path.isfile(path):
            found = "is not a regular file" if os.path.exists(path) else "not found"
            raise MclError(source.diagnostic(
                "error", f"task library {use.library!r} {found} (looked for {path})",
                use.span, f"shipped libraries: {', '.join(tasklib.SHIPPED)}; other paths are "
                "relative to the mission file", "missing-library"))
        paths.append(path)
    return paths or None


def compile_file(path: str, tasks: list[str] | None = None,
                 params: dict[str, tuple[ast.Value, Source]] | None = None,
                 require_values: bool = False) -> Compiled:
    source = read_source(path)
    return compile_source(source, tasks, params, require_values)


def compile_source(source: Source, tasks: list[str] | None = None,
                   params: dict[str, tuple[ast.Value, Source]] | None = None,
                   require_values: bool = False,
                   library: tasklib.Library | None = None) -> Compiled:
    mission = parser.parse(source)
    lib = library or tasklib.load(tasks or _uses(mission, source))
    checked = checker.check_mission(mission, lib, source, params, require_values)
    net = compiler.compile_mission(checked)
    return Compiled(mission, checked, net, source)
