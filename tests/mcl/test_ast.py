"""mcl/ast.py on its own: frozen nodes whose equality ignores spans, and walking a tree.

``children`` gives a block's direct children in source order, ``walk`` every block parents
first (without recursion, so that a deep tree is fine), ``calls`` the task calls in order.
"""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given

from diagnostics import Span
from mcl import ast
from tests import strategies as S

A, B, C, D = (ast.Call(x, ()) for x in "ABCD")


def test_equality_ignores_spans_but_not_content() -> None:
    here, there = Span("a.mcl", 1, 1), Span("b.mcl", 9, 9)
    assert ast.Call("A", (), here) == ast.Call("A", (), there)
    assert ast.Number(1.0, "m", here) == ast.Number(1.0, "m", there)
    assert ast.Number(1.0, "m") != ast.Number(1.0, "cm")
    assert ast.Arg(ast.Ref("x"), "timeout") != ast.Arg(ast.Ref("x"))
    assert ast.Mission("m", A) != ast.Mission("n", A)


def test_nodes_are_frozen_and_hashable() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        A.name = "B"  # type: ignore[misc]
    assert len({ast.Call("A", ()), ast.Call("A", (), Span("x", 2, 2)), B}) == 2


@pytest.mark.parametrize("block,kids", [
    (A, ()),
    (ast.Sequence((A, B, C)), (A, B, C)),
    (ast.TryCatchDo(A, B, C), (A, B, C)),
    (ast.ParallelAnd((A, B)), (A, B)),
    (ast.ParallelOr((C, A, B)), (C, A, B)),
    (ast.IfThenElse(A, B, C), (A, B, C)),
    (ast.IfThenElse(A, B, None), (A, B)),
    (ast.WhileDo(A, B), (A, B)),
])
def test_children_in_source_order(block: ast.Block, kids: tuple[ast.Block, ...]) -> None:
    assert ast.children(block) == kids


def test_children_of_something_else_is_a_type_error() -> None:
    with pytest.raises(TypeError, match="not a block"):
        ast.children(ast.Number(1.0))  # type: ignore[arg-type]


def test_walk_is_parents_first_in_source_order_and_calls_are_the_leaves() -> None:
    inner = ast.Sequence((B, C))
    tree = ast.TryCatchDo(ast.WhileDo(A, inner), D, ast.IfThenElse(A, B, None))
    order = ast.walk(tree)
    assert order[0] is tree
    assert [type(b).__name__ for b in order] == [
        "TryCatchDo", "WhileDo", "Call", "Sequence", "Call", "Call", "Call", "IfThenElse",
        "Call", "Call"]
    assert [c.name for c in ast.calls(tree)] == ["A", "B", "C", "D", "A", "B"]


def test_walk_handles_a_tree_deeper_than_the_recursion_limit() -> None:
    tree: ast.Block = A
    for _ in range(5000):
        tree = ast.WhileDo(tree, B)
    assert len(ast.walk(tree)) == 5000 + 1 + 5000
    assert [c.name for c in ast.calls(tree)][:2] == ["A", "B"]


@given(S.generic_missions(max_depth=3, max_calls=6))
def test_walk_visits_each_block_once_and_calls_are_its_calls(mission: ast.Mission) -> None:
    def size(b: ast.Block) -> int:
        return 1 + sum(size(c) for c in ast.children(b))

    order = ast.walk(mission.body)
    assert len(order) == size(mission.body)
    for i, b in enumerate(order):  # parents first (strategies may share a call object)
        for child in ast.children(b):
            assert any(later is child for later in order[i + 1:])
    assert ast.calls(mission.body) == [b for b in order if isinstance(b, ast.Call)]
