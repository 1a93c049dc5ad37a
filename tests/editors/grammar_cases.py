"""Test cases for the editor's TextMate grammars (editors/vscode/syntaxes/), made from the
shipped missions and task libraries with the parser's own lexer as the oracle.

Each file is copied with a ``// SYNTAX TEST`` header and, under each line, assertions in the
format of ``vscode-tmgrammar-test``: the scope every token of the line must have, as lark's
lexer (the grammar of ``mcl/grammar/``) reads it. The grammar passes when it colours every
keyword, name, number, unit, string and comment of the shipped files as the parser reads them.

    python -m tests.editors.grammar_cases OUTDIR     # writes OUTDIR/*.mcl and OUTDIR/*.tasks
"""

from __future__ import annotations

import sys
from pathlib import Path

from lark import Lark, Token

from diagnostics import Source
from mcl.formatter import lexed
from tests.support import single_missions

REPO = Path(__file__).resolve().parents[2]
SHIPPED_MISSIONS = single_missions()
SHIPPED_LIBRARIES = sorted([*(REPO / "mcl" / "tasks").glob("*.tasks"),
                            *(REPO / "missions").glob("*.tasks")])
CONTROL = {"TRY", "CATCH", "DO", "PARALLEL", "AND", "OR", "IF", "THEN", "ELSE", "WHILE"}
OTHER = {"MISSION", "PARAM", "USES", "ON", "STOP"}
CLAUSES = {"start", "stop", "ok", "fail", "timeout", "latch", "unlatch", "estimate"}
TASK_WORDS = {"dofs", "drives", "events", "power", "in"}


def _common(tok: Token, lang: str) -> str | None:
    """The scope of a comment, number or unit, the same in both languages."""
    return {"COMMENT": "comment.line.double-slash.mcl", "BLOCK_COMMENT": "comment.block.mcl",
            "SIGNED_NUMBER": "constant.numeric.mcl", "UNIT": "keyword.other.unit.mcl",
            "STRING": f"string.quoted.double.{lang}"}.get(tok.type)


def mission_scopes(text: str) -> list[tuple[Token, str]]:
    """Each token of a mission with the scope the grammar must give it."""
    tokens = lexed(Source("case.mcl", text))
    code = [t for t in tokens if t.type not in ("COMMENT", "BLOCK_COMMENT")]
    after = {id(a): b for a, b in zip(code, code[1:], strict=False)}
    before = {id(b): a for a, b in zip(code, code[1:], strict=False)}
    out = []
    for tok in tokens:
        scope = _common(tok, "mcl")
        nxt, prev = after.get(id(tok)), before.get(id(tok))
        if scope is None and tok.value in CONTROL:
            scope = "keyword.control.mcl"
        elif scope is None and tok.value in OTHER:
            scope = "keyword.other.mcl"
        elif scope is None and tok.type == "NAME":
            if prev is not None and prev.value == "MISSION":
                scope = "entity.name.section.mcl"
            elif prev is not None and prev.value == "PARAM":
                scope = "variable.other.constant.mcl"
            elif nxt is not None and nxt.value == "(":
                scope = "entity.name.function.mcl"
            elif tok.value in ("enable", "disable"):
                scope = "constant.language.mcl"
            elif nxt is not None and nxt.value == "=":
                scope = "variable.parameter.mcl"
            else:
                scope = "variable.other.mcl"
        if scope is not None:
            out.append((tok, scope))
    return out


def library_scopes(text: str) -> list[tuple[Token, str]]:
    """Each token of a task library with the scope the grammar must give it (keywords,
    declared names, numbers, units, comments)."""
    comments: list[Token] = []
    parser = Lark.open_from_package("mcl", "tasks.lark", ("grammar",), parser="lalr",
                                    propagate_positions=True, keep_all_tokens=True,
                                    start="library", lexer_callbacks={
                                        "COMMENT": comments.append,
                                        "BLOCK_COMMENT": comments.append})
    code = list(parser.parse(text).scan_values(lambda v: isinstance(v, Token)))
    code.sort(key=lambda t: t.start_pos or 0)
    out = []
    for i, tok in enumerate(code):
        nxt = code[i + 1] if i + 1 < len(code) else None
        prev = code[i - 1] if i else None
        scope = _common(tok, "mcl-tasks")
        if scope is None and tok.value in CLAUSES and nxt is not None and nxt.value == ":":
            scope = "keyword.control.clause.mcl-tasks"
        elif scope is None and tok.value in ("task", "behaviour"):
            scope = f"keyword.other.{tok.value}.mcl-tasks"
        elif scope is None and tok.value in TASK_WORDS and tok.type != "NAME":
            scope = "keyword.other.mcl-tasks"
        elif scope is None and tok.type == "NAME" and prev is not None:
            scope = {"task": "entity.name.function.mcl-tasks",
                     "behaviour": "entity.name.type.mcl-tasks"}.get(prev.value)
        if scope is not None:
            out.append((tok, scope))
    return sorted([*out, *((c, _common(c, "mcl-tasks") or "") for c in comments)],
                  key=lambda pair: pair[0].start_pos or 0)


def with_assertions(text: str, scope_name: str, title: str,
                    scoped: list[tuple[Token, str]]) -> str:
    """The file with a SYNTAX TEST header and, under each line, one assertion per token."""
    by_line: dict[int, list[tuple[int, int, str]]] = {}
    for tok, scope in scoped:
        first = tok.value.split("\n", 1)[0].rstrip("\r")
        col = (tok.column or 1) - 1
        if col == 1 or not first:
            continue  # '// ^' cannot point at the second column
        by_line.setdefault(tok.line or 1, []).append((col, len(first), scope))
    out = [f'// SYNTAX TEST "{scope_name}" "{title}"']
    for number, line in enumerate(text.splitlines(), 1):
        out.append(line)
        for col, length, scope in by_line.get(number, []):
            if col == 0:
                out.append("// <" + "-" * length + " " + scope)
            else:
                out.append("//" + " " * (col - 2) + "^" * length + " " + scope)
    return "\n".join(out) + "\n"


def write_cases(folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for path in SHIPPED_MISSIONS:
        text = path.read_text("utf-8")
        case = folder / path.name
        case.write_text(with_assertions(text, "source.mcl", path.name, mission_scopes(text)),
                        "utf-8")
        written.append(case)
    for path in SHIPPED_LIBRARIES:
        text = path.read_text("utf-8")
        case = folder / f"{path.parent.name}_{path.name}"
        case.write_text(with_assertions(text, "source.mcl-tasks", path.name,
                                        library_scopes(text)), "utf-8")
        written.append(case)
    return written


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -m tests.editors.grammar_cases OUTDIR")
    for case in write_cases(Path(sys.argv[1])):
        print(case)
