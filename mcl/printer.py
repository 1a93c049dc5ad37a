"""Pretty-print a mission back to MCL (canonical layout; parse(print(m)) == m)."""

from __future__ import annotations

from mcl import ast
from mcl.values import to_text

INDENT = "    "


def call(c: ast.Call) -> str:
    args = [(f"{a.name} = " if a.name else "") + to_text(a.value) for a in c.args]
    return f"{c.name}({', '.join(args)})"


def mission(m: ast.Mission) -> str:
    lines = [f'USES "{u.library}";' for u in m.uses]
    lines += [f"PARAM {p.name}" + (f" = {to_text(p.value)}" if p.value is not None else "") + ";"
             for p in m.params]
    head = "MISSION" + (f" {m.name}" if m.name else "")
    stop = f" ON STOP {block(m.on_stop, 0)}" if m.on_stop is not None else ""
    lines.append(f"{head} {block(m.body, 0)}{stop}")
    return "\n".join(lines) + "\n"


def block(b: ast.Block, depth: int) -> str:
    """A braced block at the given indentation depth."""
    items = b.items if isinstance(b, ast.Sequence) else (b,)
    inner = INDENT * (depth + 1)
    body = ";\n".join(inner + item(i, depth + 1) for i in items)
    return "{\n" + body + "\n" + INDENT * depth + "}"


def item(b: ast.Block, depth: int) -> str:
    match b:
        case ast.Call():
            return call(b)
        case ast.Sequence():  # a nested sequence only arises from a braced block
            return block(b, depth)
        case ast.TryCatchDo(try_=t, catch=c, do=d):
            return f"TRY {block(t, depth)} CATCH {block(c, depth)} DO {block(d, depth)}"
        case ast.ParallelAnd(branches=bs):
            return "PARALLEL " + " AND ".join(block(x, depth) for x in bs)
        case ast.ParallelOr(branches=bs):
            return "PARALLEL " + " OR ".join(block(x, depth) for x in bs)
        case ast.IfThenElse(condition=c, then=t, else_=e):
            text = f"IF {block(c, depth)} THEN {block(t, depth)}"
            return text + (f" ELSE {block(e, depth)}" if e is not None else "")
        case ast.WhileDo(condition=c, body=body):
            return f"WHILE {block(c, depth)} DO {block(body, depth)}"
    raise TypeError(f"not a block: {b!r}")
