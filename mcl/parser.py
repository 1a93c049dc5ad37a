"""Parse MCL text into the AST, turning raw parse errors into messages a mission author can act on.

The grammar is the data file ``mcl/grammar/mcl.lark``. Known mistakes are recognised by
:data:`KNOWN_MISTAKES` (lark's ``match_examples``: each entry lists small programs that go
wrong in the same way); the same table is exercised by the tests.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import diagnostics
from diagnostics import MclError, Source, Span, error, read_source

from mcl import ast, cache, grammars
from mcl.ast_builder import AstBuilder, token_span
from mcl.syntax import Token, Tree

if TYPE_CHECKING:
    from lark import Lark, UnexpectedInput

KEYWORDS = ("MISSION", "PARAM", "USES", "TRY", "CATCH", "DO", "PARALLEL", "AND", "OR", "IF", "THEN",
            "ELSE", "WHILE", "ON", "STOP")
# the words of a fleet (docs/LANGUAGE.md, "Fleets"): keywords only where a fleet is written
FLEET_KEYWORDS = ("FLEET", "VEHICLE", "CHANNEL", "FROM", "TO", "ACOUSTIC", "RADIO", "TETHER",
                  "DELAY", "EVERY", "LOSSY", "MESSAGES")
NAME_LIST_END = {"SEMICOLON", "COMMA", "ACOUSTIC", "RADIO", "TETHER"}  # after a CHANNEL's names
MAX_DEPTH = 100  # blocks nested deeper than this are refused ("absurd nesting")

# code -> (message, hint, examples that fail in the same parser state)
KNOWN_MISTAKES: dict[str, tuple[str, str, list[str]]] = {
    "trailing-semicolon": (
        "';' before '}': in MCL ';' separates items, so the last item of a block has none",
        "delete this ';'",
        ["MISSION { A(); }", "MISSION { A(); B(); }", "MISSION { TRY { A(); } CATCH { B() } DO { C() } }"],
    ),
    "missing-brace-before-catch": (
        "'}' missing before CATCH: the TRY block is not closed",
        "write '} CATCH {' — the block after TRY must be closed before CATCH",
        ["MISSION { TRY { A() CATCH { B() } DO { C() } }",
         "MISSION { TRY { A(); B() CATCH { B() } DO { C() } }"],
    ),
    "missing-brace-before-do": (
        "'}' missing before DO: the block before DO is not closed",
        "close the CATCH (or WHILE) block with '}' before DO",
        ["MISSION { TRY { A() } CATCH { B() DO { C() } }",
         "MISSION { WHILE { A() DO { C() } }"],
    ),
    "missing-brace-before-then-else": (
        "'}' missing: the block before THEN / ELSE is not closed",
        "close the block with '}' before the keyword",
        ["MISSION { IF { A() THEN { B() } }", "MISSION { IF { A() } THEN { B() ELSE { C() } }"],
    ),
    "mixed-and-or": (
        "AND and OR mixed in one PARALLEL",
        "use one kind per PARALLEL; nest a PARALLEL inside a branch to combine them",
        ["MISSION { PARALLEL { A() } AND { B() } OR { C() } }",
         "MISSION { PARALLEL { A() } OR { B() } AND { C() } }"],
    ),
    "missing-semicolon": (
        "';' missing between two items",
        "separate the items of a block with ';'",
        ["MISSION { A() B() }", "MISSION { A() TRY { B() } CATCH { C() } DO { D() } }",
         "MISSION { TRY { B() } CATCH { C() } DO { D() } A() }"],
    ),
    "empty-block": (
        "empty block: a block holds at least one item",
        "put a task in the block, e.g. Wait(0)",
        ["MISSION { }", "MISSION { TRY { } CATCH { A() } DO { B() } }"],
    ),
    "missing-mission": (
        "the file has no MISSION",
        "write the mission as MISSION { ... } after any PARAM lines",
        ["PARAM a = 1;", "A()"],
    ),
    "unclosed-block": (
        "the file ends inside a block: a '}' is missing",
        "close every '{' with a '}'",
        ["MISSION { A()", "MISSION { TRY { A() } CATCH { B() } DO { C() }"],
    ),
    "missing-block-after": (
        "a block in braces is expected here",
        "control structures take blocks: TRY { ... } CATCH { ... } DO { ... }",
        ["MISSION { TRY A() }", "MISSION { PARALLEL { A() } AND B() }", "MISSION { IF A() }"],
    ),
    "call-needs-parentheses": (
        "a task call needs parentheses",
        "write Name() even when the task takes no arguments",
        ["MISSION { A }", "MISSION { A; B() }"],
    ),
    "text-after-mission": (
        "text after the end of the mission",
        "a file holds one MISSION; remove what follows its closing '}'",
        ["MISSION { A() } B()", "MISSION { A() } }"],
    ),
}


@lru_cache(maxsize=1)
def mission_parser() -> grammars.Standalone:
    """The parser of ``mcl/grammar/mcl.lark`` (lark's standalone module, mcl/grammars.py) and
    the classes of the errors it raises."""
    return grammars.standalone("mcl.lark", parser="lalr", propagate_positions=True,
                               maybe_placeholders=True, start=["start", "value"])


def _lark() -> Lark:
    return mission_parser().parser


def parse_file(path: str) -> ast.Mission:
    """Read and parse a mission file; every problem becomes an :class:`MclError`."""
    return parse(read_source(path))


def parse(source: Source) -> ast.Mission:
    """Parse a single-vehicle mission; a fleet file is refused with a clear message (commands
    that take fleets read them with :func:`parse_unit`)."""
    unit = parse_unit(source)
    if isinstance(unit, ast.Fleet):
        raise error(source, f"this file is a fleet (FLEET {unit.name}), not a single mission",
                    source.span(unit.span.line, unit.span.col),
                    "this command takes one vehicle's mission; mclc and mcl run take fleets",
                    code="fleet-file")
    return unit


def parse_unit(source: Source) -> ast.Mission | ast.Fleet:
    """Parse a mission file or a fleet file (docs/LANGUAGE.md, "Fleets"); within
    :func:`trees_kept`, a text parsed before is loaded from the cache instead."""
    if not source.text.strip():
        raise error(source, "the file is empty", source.span(1, 1),
                    "a mission file holds MISSION { ... }", code="empty-file")
    if not KEEP_TREES:
        return parse_text(source)
    where = cache.SHA256(os.path.abspath(source.name).encode()).hexdigest()[:16]
    parsed: list[ast.Mission | ast.Fleet] = []

    def parse() -> ast.Mission | ast.Fleet:
        parsed.append(parse_text(source))
        return parsed[0]

    unit = cache.cached(f"syntax-{where}", lambda: [
        "syntax 1", source.name, source.text, grammars.grammar_text("mcl.lark"),
        grammars.lark_version(), cache.code_digest(TREE_CODE)], parse)
    if parsed:
        cache.prune("syntax-", KEEP_TREES_OF)
    return unit


# Whether parse_unit keeps the syntax tree of each text in the cache (mcl/cache.py), one entry
# per file (for the KEEP_TREES_OF files parsed last), and loads it from there when the file's
# text, the grammar, lark's version and the code are those it was parsed with: on within
# trees_kept() (mclc, which parses the same files call after call: about a fifth of its time
# for the dam), off elsewhere (an editor's or a test's texts are parsed once each, and would
# only fill the cache).
KEEP_TREES = False
KEEP_TREES_OF = 500  # files whose trees are kept: those parsed last
TREE_CODE = (Path(__file__).parent, Path(diagnostics.__file__).parent)  # the parser, the AST


@contextmanager
def trees_kept() -> Iterator[None]:
    """Within it, parse_unit keeps syntax trees in the cache (:data:`KEEP_TREES`)."""
    global KEEP_TREES
    before, KEEP_TREES = KEEP_TREES, True
    try:
        yield
    finally:
        KEEP_TREES = before


def parse_text(source: Source) -> ast.Mission | ast.Fleet:
    """Parse a mission file or a fleet file, never from the cache."""
    try:
        tree = _lark().parse(source.text, start="start")
    except mission_parser().unexpected_input as exc:
        raise _friendly(source, exc) from None
    check_depth(source, tree)
    return AstBuilder(source).unit(tree)


def parse_value(text: str, origin: str = "<command line>", line: int = 1,
                column: int = 1) -> ast.Value:
    """Parse one parameter value as written on the command line or in a parameter file;
    ``line`` and ``column`` say where it starts in ``origin`` (for the spans of messages)."""
    # Blanks the grammar ignores put the value where it was written, so every position the
    # parser reports (and every span of the AST) is already a place in ``origin``.
    padded = "\n" * (line - 1) + " " * (column - 1) + text
    source = Source(origin, padded)
    try:
        tree = _lark().parse(padded, start="value")
    except mission_parser().unexpected_input as exc:
        token = getattr(exc, "token", None)
        ended = isinstance(exc, mission_parser().unexpected_eof) or getattr(token, "type", "") == "$END"
        at = (source.span(line, column + len(text.rstrip())) if ended or exc.line < 1
              else source.span(exc.line, max(exc.column, 1)))  # at the end: after the value
        raise error(source, f"not a value: {text!r}", at,
                    "values are numbers with an optional unit (1.5 m), lists [a, b], "
                    "points (x, y, z, yaw) or names", code="bad-value") from None
    check_depth(source, tree)
    return AstBuilder(source).value(tree)


# -- friendly syntax errors ------------------------------------------------------------------
def _friendly(source: Source, exc: UnexpectedInput) -> MclError:
    errors = mission_parser()
    line, col = max(exc.line, 1), max(exc.column, 1)
    if isinstance(exc, errors.unexpected_characters):
        pos = exc.pos_in_stream or 0
        char = source.text[pos] if pos < len(source.text) else ""
        if source.text.startswith("/*", pos):
            return error(source, "comment '/*' is never closed", source.span(line, col),
                         "close it with '*/'", code="unclosed-comment")
        return error(source, f"unexpected character {char!r}", source.span(line, col),
                     "MCL uses letters, digits, _ ( ) [ ] { } , ; = . and comments",
                     code="bad-character")
    token = (exc.token if isinstance(exc, (errors.unexpected_token, errors.unexpected_eof))
             else None)
    previous = _token_before(source, line, col)
    # Lower-case keywords: "try {" reads as a task named try followed by '{'.
    if isinstance(token, Token) and previous is not None and previous.type == "NAME":
        if previous.upper() in KEYWORDS and previous != previous.upper():
            return error(source, f"keywords are upper case: write {previous.upper()}, "
                         f"not {previous}", token_span(source, previous),
                         f"replace '{previous}' with '{previous.upper()}'",
                         code="lower-case-keyword")
    if (isinstance(token, Token) and token.type == "NAME" and token.upper() in KEYWORDS
            and str(token) != token.upper()):
        return error(source, f"keywords are upper case: write {token.upper()}, not {token}",
                     token_span(source, token), f"replace '{token}' with '{token.upper()}'",
                     code="lower-case-keyword")
    if isinstance(token, Token):
        fleet = _fleet_mistake(source, token, previous, getattr(exc, "expected", None) or set())
        if fleet is not None:
            return fleet
    code = _after_item(exc, token, known_mistake(exc))
    if code is not None:
        message, hint, _ = KNOWN_MISTAKES[code]
        span = source.span(line, col)
        if code in ("trailing-semicolon", "call-needs-parentheses") and previous is not None:
            span = token_span(source, previous)  # point at the ';' itself
        if code == "missing-semicolon" and previous is not None:
            span = source.span(previous.end_line or line, (previous.end_column or col))
        if code in ("unclosed-block", "missing-mission"):
            span = _end_span(source)
        if code == "text-after-mission" and isinstance(token, Token):
            span = token_span(source, token)
        return error(source, message, span, hint, code=code)
    if isinstance(exc, errors.unexpected_eof) or (isinstance(token, Token)
                                                   and token.type == "$END"):
        return error(source, "unexpected end of file", _end_span(source),
                     "a '}' or an item may be missing", code="unexpected-eof")
    assert isinstance(token, Token)
    if token.type == "NAME" and previous is not None and previous.type == "SIGNED_NUMBER":
        return error(source, f"unknown unit '{token}'", token_span(source, token),
                     "units: m, cm, mm, km (length); deg, rad (angle); s, ms, min, h (time)",
                     code="unknown-unit")
    expected = sorted(_pretty_terminal(t) for t in getattr(exc, "expected", ()) or ())
    return error(source, f"unexpected {_pretty_token(token)}", token_span(source, token),
                 f"expected {_one_of(expected)}" if expected else "", code="syntax")


def _fleet_mistake(source: Source, token: Token, previous: Token | None,
                   expects: set[str]) -> MclError | None:
    """The mistakes only a fleet file can make, told by the token that came and what the
    parser expected instead (None: none of them)."""
    if token.type == "NAME" and token.upper() in expects and token.upper() in FLEET_KEYWORDS:
        return error(source, f"keywords are upper case: write {token.upper()}, not {token}",
                     token_span(source, token), f"replace '{token}' with '{token.upper()}'",
                     code="lower-case-keyword")
    if first_word(source.text) != "FLEET":
        return None
    if (token.type in ("CHANNEL", "VEHICLE", "RBRACE") and previous is not None
            and {"SEMICOLON", "COMMA"} <= expects <= NAME_LIST_END):
        # the end of a CHANNEL's MESSAGES list (the only place a list of names can end)
        return error(source, "';' missing at the end of the CHANNEL declaration",
                     source.span(previous.end_line or token.line or 1,
                                 previous.end_column or token.column or 1),
                     "end each CHANNEL ... MESSAGES a, b with ';'", code="missing-semicolon")
    if token.type == "RBRACE" and "MISSION" in expects:  # a VEHICLE's headers, no MISSION
        return error(source, "the VEHICLE has no MISSION", token_span(source, token),
                     "write its mission inside it: VEHICLE name { ...; MISSION { ... } }",
                     code="missing-mission")
    if token.type == "MISSION" and {"ON", "RBRACE"} <= expects:  # after a vehicle's mission
        return error(source, "a VEHICLE holds one MISSION", token_span(source, token),
                     "close the VEHICLE with '}' after its mission (and its ON STOP)",
                     code="text-after-mission")
    if expects == {"<END-OF-FILE>"} or expects == {"$END"}:  # after the fleet's '}'
        return error(source, "text after the end of the fleet", token_span(source, token),
                     "a file holds one FLEET; remove what follows its closing '}'",
                     code="text-after-mission")
    return None


def is_fleet(path_or_source: str | Source) -> bool:
    """Whether a file (a path, or its source) is a fleet: its first word is FLEET. A file
    that cannot be read is not one (reading it again reports why), nor is one that is not a
    regular file: a named pipe (``mclc <(...)``) can be read only once, so ask of its source."""
    if isinstance(path_or_source, Source):
        text = path_or_source.text
    else:
        try:
            if not stat.S_ISREG(os.stat(path_or_source).st_mode):
                return False
            with open(path_or_source, encoding="utf-8", errors="replace") as f:
                text = f.read(65536)
        except (OSError, ValueError):  # ValueError: a path with a NUL byte
            return False
    return first_word(text) == "FLEET"


def first_word(text: str) -> str:
    """The first word of MCL text, comments skipped (``FLEET`` for a fleet file)."""
    i, n = 0, len(text)
    while i < n:
        if text[i].isspace():
            i += 1
        elif text.startswith("//", i):
            end = text.find("\n", i)
            i = n if end < 0 else end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            i = n if end < 0 else end + 2
        else:
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            return text[i:j]
    return ""


def known_mistake(exc: UnexpectedInput) -> str | None:
    """The code of the :data:`KNOWN_MISTAKES` entry whose examples fail as ``exc`` does: in the
    same parser state, expecting the same tokens, preferably at a token of the same type (a
    file that ends where a '}' could come ends inside a block, whatever else could come).

    Unlike lark's ``match_examples``, which also asks for the same depth of the parser's stack,
    this does not depend on what comes before the mistake (PARAM lines, enclosing blocks)."""
    errors = mission_parser()
    state = exc.state
    if state is None or not isinstance(exc, (errors.unexpected_token, errors.unexpected_eof)):
        return None
    accepts = getattr(exc, "accepts", None)
    candidate = None
    for code, (_, _, examples) in KNOWN_MISTAKES.items():
        for example in examples:
            try:
                _lark().parse(example, start="start")
            except (errors.unexpected_token, errors.unexpected_eof) as seen:
                if (seen.state is None or seen.state.position != state.position
                        or getattr(seen, "accepts", None) != accepts):
                    continue
                if seen.token.type == exc.token.type:
                    return code
                candidate = candidate or code
    if exc.token.type == "$END" and "RBRACE" in (accepts or ()):
        return "unclosed-block"  # whatever else could have come, the file ended inside a block
    return candidate


# After a whole item of a block (a ';' or a '}' may come next), the parser is in the same state
# whichever item it was, so match_examples tells these mistakes apart by the token that came.
AFTER_ITEM = {"CATCH": "missing-brace-before-catch", "DO": "missing-brace-before-do",
              "THEN": "missing-brace-before-then-else", "ELSE": "missing-brace-before-then-else",
              **{t: "missing-semicolon" for t in ("NAME", "TRY", "PARALLEL", "IF", "WHILE")}}


def _after_item(exc: UnexpectedInput, token: Token | None, code: str | None) -> str | None:
    """The mistake an unexpected token right after an item of a block is (``code``, what
    match_examples found, when the token says nothing more)."""
    accepts = getattr(exc, "accepts", None) or getattr(exc, "expected", None) or set()
    if (token is None or token.type not in AFTER_ITEM or not {"RBRACE", "SEMICOLON"} <= accepts
            or code not in (None, *AFTER_ITEM.values())):
        return code
    return AFTER_ITEM[token.type]


def _token_before(source: Source, line: int, col: int) -> Token | None:
    """The last token that ends before (line, col), or None."""
    previous = None
    try:
        for tok in _lark().lex(source.text):
            if (tok.line, tok.column) >= (line, col):
                break
            previous = tok
    except mission_parser().unexpected_input:
        pass
    return previous


def _end_span(source: Source) -> Span:
    lines = source.text.rstrip().split("\n") or [""]  # lines as the parser counts them
    return source.span(len(lines), len(lines[-1].removesuffix("\r")) + 1)


_TERMINAL_NAMES = {"LBRACE": "'{'", "RBRACE": "'}'", "LPAR": "'('", "RPAR": "')'",
                   "LSQB": "'['", "RSQB": "']'", "SEMICOLON": "';'", "COMMA": "','",
                   "EQUAL": "'='", "_DOTS": "'..'", "STRING": "a \"string\"", "NAME": "a name", "SIGNED_NUMBER": "a number",
                   "UNIT": "a unit", "$END": "the end of the file"}


def _pretty_terminal(name: str) -> str:
    if name in _TERMINAL_NAMES:
        return _TERMINAL_NAMES[name]
    return name if name in KEYWORDS or name in FLEET_KEYWORDS else name.lower()


def _pretty_token(tok: Token) -> str:
    if tok.type == "NAME":
        return f"name '{tok}'"
    if tok.type == "SIGNED_NUMBER":
        return f"number {tok}"
    return f"'{tok}'"


def _one_of(items: list[str]) -> str:
    return items[0] if len(items) == 1 else "one of " + ", ".join(items)


def check_depth(source: Source, tree: Tree[Token]) -> None:
    """Refuse absurd nesting before anything recursive walks the tree."""
    stack: list[tuple[Tree[Token], int]] = [(tree, 0)]
    steps = 0
    while stack:
        node, depth = stack.pop()
        steps += 1
        if node.data in ("block", "list", "point"):
            depth += 1
            if depth > MAX_DEPTH:
                meta = node.meta
                what = "blocks" if node.data == "block" else "blocks and values"
                raise error(source, f"{what} nested more than {MAX_DEPTH} deep",
                            source.span(meta.line, meta.column),
                            "flatten the mission: deep nesting is almost always a mistake",
                            code="too-deep")
        stack.extend((c, depth) for c in node.children if isinstance(c, Tree))


def suggest(name: str, candidates: list[str]) -> str:
    """' (did you mean X?)' for a close match, else ''."""
    import difflib  # lazy for start-up speed: only a message with a suggestion needs it

    close = difflib.get_close_matches(name, candidates, n=1, cutoff=0.6)
    if not close:
        lowered = {c.lower(): c for c in candidates}
        if name.lower() in lowered:
            close = [lowered[name.lower()]]
    return f"did you mean {close[0]}?" if close else ""
