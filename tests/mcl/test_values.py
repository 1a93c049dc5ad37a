"""mcl/values.py on its own: kinds, units, the two checks of a value, and its JSON.

``check`` looks at a value's shape against the kind a formal declares (and records the kind of
each mission parameter at its first use); ``limits`` at the numbers it carries once parameters
have values (finite, durations not negative, in a declared range, points with the fields the
formal needs); ``evaluate`` gives what an action carries, in base units; ``to_text`` writes a
value back as MCL.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mcl import ast
from mcl.parser import parse_value
from mcl.values import (
    FIELDS,
    KINDS,
    UNITS,
    Problem,
    Range,
    Unresolved,
    base,
    check,
    describe,
    evaluate,
    limits,
    to_text,
)

N = ast.Number


def _messages(problems: list[Problem]) -> list[str]:
    return [p.message for p in problems]


# -- units -------------------------------------------------------------------------------
@pytest.mark.parametrize("number,expected", [
    (N(2, "km"), 2000.0), (N(20, "cm"), 0.2), (N(5, "mm"), 0.005), (N(3, "m"), 3.0),
    (N(math.pi, "rad"), 180.0), (N(90, "deg"), 90.0),
    (N(2, "min"), 120.0), (N(1, "h"), 3600.0), (N(250, "ms"), 0.25), (N(7), 7.0),
])
def test_base_converts_to_metres_degrees_and_seconds(number: ast.Number,
                                                    expected: float) -> None:
    assert base(number) == pytest.approx(expected)


def test_every_unit_has_a_numeric_kind() -> None:
    assert {kind for kind, _ in UNITS.values()} == {"length", "angle", "duration"}
    assert set(KINDS) >= {"number", "length", "angle", "duration", "point", "path", "list"}
    assert FIELDS == ("x", "y", "z", "yaw")


@pytest.mark.parametrize("value,text", [
    (N(1, "km"), "a length (km)"), (N(1), "a number"), (ast.Ref("d"), "'d'"),
    (ast.ListValue(()), "a list"), (ast.Point((N(1), N(2))), "a point of 2"),
])
def test_describe_says_what_a_value_is(value: ast.Value, text: str) -> None:
    assert describe(value) == text


# -- check: the shape ---------------------------------------------------------------------
@pytest.mark.parametrize("value,kind", [
    (N(1), "length"), (N(1, "cm"), "length"), (N(1, "rad"), "angle"), (N(1, "ms"), "duration"),
    (N(-4), "number"),
    (ast.Point((N(1), N(2))), "point"), (ast.Point((N(1), N(2), N(3, "m"), N(9, "deg"))), "point"),
    (ast.ListValue((ast.Point((N(0), N(1))), ast.Ref("lane"))), "path"),  # a spliced path
    (ast.ListValue((N(1), ast.Ref("x"))), "list"),
])
def test_check_accepts_each_kind_as_written(value: ast.Value, kind: str) -> None:
    assert check(value, kind, {}) == []


@pytest.mark.parametrize("value,kind,message", [
    (N(1, "s"), "length", "expected a length, got a duration (s)"),
    (N(1, "m"), "number", "expected a number, got a length (m)"),
    (ast.Point((N(1),)), "point", "expected a point (x, y, z, yaw) of 2 to 4 numbers, got a "
     "point of 1"),
    (ast.Point((N(1), N(1, "deg"))), "point", "expected a length, got a angle (deg)"),
    (N(3), "path", "expected a path [(y, z), ...], got a number"),
    (ast.Point((N(1), N(2))), "list", "expected a list [a, b, ...], got a point of 2"),
    (ast.Ref("enable"), "length", "'enable' is a word, but a length is expected here"),
])
def test_check_refuses_a_wrong_shape_naming_the_node(value: ast.Value, kind: str,
                                                     message: str) -> None:
    problems = check(value, kind, {})
    assert _messages(problems) == [message]


def test_check_records_a_parameters_kind_at_its_first_use() -> None:
    kinds: dict[str, str] = {}
    assert check(ast.Ref("d"), "length", kinds) == [] and kinds == {"d": "length"}
    assert _messages(check(ast.Ref("d"), "angle", kinds)) == [
        "parameter 'd' is used as a angle here but as a length elsewhere"]
    assert check(ast.Ref("d"), "list", kinds) == []  # anything goes into a list
    kinds["lane"] = "path"
    assert check(ast.Ref("lane"), "list", kinds) == []


def test_check_of_an_unknown_kind_is_a_programming_error() -> None:
    with pytest.raises(ValueError, match="unknown kind colour"):
        check(N(1), "colour", {})


# -- limits: the numbers ------------------------------------------------------------------
def test_range_is_closed_and_may_be_open_on_one_side() -> None:
    r = Range(0.0, 3.0, "in [0 m, 3 m]")
    assert 0.0 in r and 3.0 in r and -0.1 not in r and 3.1 not in r
    assert 1e300 in Range(0.0, None, ">= 0 m") and -1 not in Range(0.0, None, ">= 0 m")


@pytest.mark.parametrize("value,kind,code", [
    (N(-1, "s"), "duration", "negative-duration"),
    (N(1e308, "h"), "duration", "number-out-of-range"),
    (N(1e308, "km"), "length", "number-out-of-range"),
    (ast.Point((N(1), N(2))), "point", "missing-field"),
    (ast.ListValue((N(1e308, "km"),)), "list", "number-out-of-range"),
])
def test_limits_finds_each_problem_with_its_code(value: ast.Value, kind: str,
                                                 code: str) -> None:
    assert [p.code for p in limits(value, kind, {})] == [code]


def test_limits_checks_a_declared_range() -> None:
    r = Range(0.0, 3.0, "in [0 m, 3 m]")
    assert limits(N(300, "cm"), "length", {}, r) == []
    (p,) = limits(N(5, "m"), "length", {}, r)
    assert (p.code, p.message) == ("value-out-of-range",
                                   "5 m is out of range: it must be in [0 m, 3 m]")


def test_limits_follows_parameters_and_names_the_one_it_came_from() -> None:
    env: dict[str, ast.Value] = {"a": ast.Ref("b"), "b": N(-1, "min")}
    (p,) = limits(ast.Ref("a"), "duration", env)
    assert (p.code, p.param, p.message) == (
        "negative-duration", "b", "a duration cannot be negative, got -1 min")
    assert limits(ast.Ref("unset"), "duration", env) == []  # checked once it has a value
    assert limits(ast.Ref("a"), "duration", {"a": ast.Ref("a")}) == []  # a cycle: the checker's


def test_limits_asks_a_point_for_the_fields_its_formal_needs() -> None:
    env: dict[str, ast.Value] = {"p": ast.Point((N(1), N(2)))}
    (p,) = limits(ast.Ref("p"), "point", env, fields=3)
    assert p.message == ("the point (1, 2) has 2 fields: z is missing (a point here is "
                         "(x, y, z[, yaw]))")
    assert limits(ast.Ref("p"), "point", env, fields=2) == []
    # the points of a path need no fields beyond what they give
    assert limits(ast.ListValue((ast.Point((N(1), N(2))),)), "path", {}) == []


# -- evaluate: what an action carries -------------------------------------------------------
def test_evaluate_gives_base_units_following_parameters() -> None:
    env: dict[str, ast.Value] = {"d": N(150, "cm"), "e": ast.Ref("d")}
    assert evaluate(ast.Ref("e"), "length", env) == pytest.approx(1.5)
    assert evaluate(ast.Point((N(1, "km"), N(2), N(3, "m"), N(math.pi, "rad"))), "point",
                    {}) == pytest.approx([1000.0, 2.0, 3.0, 180.0])


def test_evaluate_splices_a_path_parameter_into_a_path() -> None:
    env: dict[str, ast.Value] = {"lane": ast.ListValue((ast.Point((N(3), N(4))),))}
    path = ast.ListValue((ast.Point((N(1, "km"), N(2))), ast.Ref("lane")))
    assert evaluate(path, "path", env) == [[1000.0, 2], [3, 4]]
    assert evaluate(path, "list", env) == [[1000.0, 2], [[3, 4]]]  # a list keeps it whole


def test_evaluate_of_a_parameter_without_value_raises_unresolved_naming_it() -> None:
    with pytest.raises(Unresolved) as info:
        evaluate(ast.Point((N(1), ast.Ref("depth"))), "point", {})
    assert info.value.name == "depth"
    with pytest.raises(ValueError, match="cycle"):
        evaluate(ast.Ref("x"), "length", {"x": ast.Ref("x")})


# -- to_text: back to MCL -----------------------------------------------------------------
@pytest.mark.parametrize("value,text", [
    (N(3), "3"), (N(-3.0), "-3"), (N(0.1, "m"), "0.1 m"), (N(1e20), "1e+20"),
    (N(2.5, "min"), "2.5 min"), (ast.Ref("home"), "home"),
    (ast.ListValue((N(1), ast.ListValue(()))), "[1, []]"),
    (ast.Point((N(1, "m"), N(2), N(90, "deg"))), "(1 m, 2, 90 deg)"),
])
def test_to_text_writes_mcl(value: ast.Value, text: str) -> None:
    assert to_text(value) == text


NUMBERS = st.builds(N, st.floats(allow_nan=False, allow_infinity=False),
                    st.sampled_from([None, *UNITS]))


@given(st.recursive(NUMBERS | st.sampled_from(["a", "lane"]).map(ast.Ref),
                    lambda inner: st.lists(inner, max_size=3).map(
                        lambda xs: ast.ListValue(tuple(xs)))
                    | st.lists(inner, min_size=2, max_size=4).map(
                        lambda xs: ast.Point(tuple(xs))), max_leaves=8))
def test_to_text_parses_back_to_the_same_value(value: ast.Value) -> None:
    assert parse_value(to_text(value)) == value
