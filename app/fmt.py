"""``mcl fmt``: rewrite missions and task libraries in the one canonical layout
(mcl/formatter.py for ``.mcl`` files, mcl/tasks_formatter.py for ``.tasks`` files, docs/FMT.md).

    mcl fmt FILE|DIR...            rewrite each file that is not in the layout, in place
    mcl fmt --check FILE|DIR...    write nothing; exit 1 naming each file that would change
    mcl fmt --diff FILE|DIR...     write nothing; print what would change as a unified diff
    mcl fmt -                      read a mission on standard input, write it formatted
    mcl fmt --stdin-filename L.tasks -    the same for a task library

A directory stands for the ``.mcl`` and ``.tasks`` files under it. Exit statuses (docs/EXIT.md): 0 done (or,
with --check / --diff, nothing to change), 1 some file would change, 2 invalid input (a file
that does not parse, a missing file: nothing is written to any file then).
"""

from __future__ import annotations

import argparse
import difflib
import os
import sys
import tempfile
from pathlib import Path

from diagnostics import Source, file_error, read_source
from mcl.formatter import format_source
from mcl.tasks_formatter import format_library_source

from app import arguments
from app.guard import guarded
from mission.exits import Exit


def _parser() -> argparse.ArgumentParser:
    p = arguments.Parser(
        prog="mcl fmt",
        description="Rewrite MCL missions and task libraries in the one canonical layout, "
                    "comments kept "
                    "(docs/FMT.md). Exit 0 done, 1 a file would change (--check, --diff), "
                    "2 invalid input.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="mission files (.mcl), task libraries (.tasks), directories (their "
                        ".mcl and .tasks files), or - for standard input to standard output")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--check", action="store_true",
                      help="write nothing; name each file that would change and exit 1")
    what.add_argument("--diff", action="store_true",
                      help="write nothing; print the changes as a unified diff and exit 1 "
                           "if there are any")
    p.add_argument("--stdin-filename", metavar="NAME", default="<stdin>",
                   help="the name of the text read from standard input: a name ending in "
                        ".tasks formats it as a task library")
    p.add_argument("--debug", action="store_true", help="a traceback on an internal error")
    return p


SUFFIXES = (".mcl", ".tasks")  # the files a directory stands for


def mission_files(names: list[str]) -> list[str]:
    """The files named, a directory standing for the ``.mcl`` and ``.tasks`` files under it
    (sorted)."""
    files: list[str] = []
    for name in names:
        if name != "-" and os.path.isdir(name):
            found = sorted(str(p) for p in Path(name).rglob("*")
                           if p.suffix in SUFFIXES and p.is_file())
            if not found:
                raise file_error(name, "holds no .mcl or .tasks file", "give missions, task "
                                 "libraries or directories that hold some", code="no-missions")
            files += found
        else:
            files.append(name)
    return files


def read_mission(name: str, stdin_name: str = "<stdin>") -> Source:
    """The text of a mission or a task library to format (``-``: standard input)."""
    if name == "-":
        return Source(stdin_name, sys.stdin.read())
    return read_source(name)


def formatted(source: Source) -> str:
    """The source in the layout of its language: a ``.tasks`` name is a task library."""
    if source.name.endswith(".tasks"):
        return format_library_source(source)
    return format_source(source)


def _write(path: str, text: str) -> None:
    """Replace the file's text at once (a temporary file renamed over it), keeping its mode."""
    mode = os.stat(path).st_mode & 0o7777
    folder = os.path.dirname(os.path.abspath(path))
    fd, temporary = tempfile.mkstemp(prefix=".mcl-fmt-", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        os.chmod(temporary, mode)
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def run(args: argparse.Namespace) -> int:
    files = mission_files(args.files)
    sources = [read_mission(f, args.stdin_filename) for f in files]
    texts = [formatted(s) for s in sources]  # every file parses before any is written
    changed = 0
    for name, source, text in zip(files, sources, texts, strict=True):
        if name == "-" and not (args.check or args.diff):
            sys.stdout.write(text)
            continue
        if text == source.text:
            continue
        changed += 1
        if args.check:
            print(f"{name}: would be reformatted (mcl fmt {name})")
        elif args.diff:
            sys.stdout.writelines(difflib.unified_diff(
                source.text.splitlines(keepends=True), text.splitlines(keepends=True),
                name, f"{name} (mcl fmt)"))
        else:
            _write(name, text)
            print(f"{name}: reformatted")
    if args.check or args.diff:
        return Exit.FAILED if changed else Exit.OK
    return Exit.OK


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return guarded("fmt", args.debug, lambda: run(args))
    except OSError as exc:  # a file that cannot be written
        print(f"mcl fmt: {exc.filename}: cannot be written: {exc.strerror}", file=sys.stderr)
        return Exit.INVALID

if __name__ == "__main__":
    sys.exit(main())
