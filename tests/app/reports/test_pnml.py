"""app/reports/pnml.py: the text of a P/T net's state-space report."""

from __future__ import annotations

from app.reports.pnml import pnml_text


def test_a_line_per_answer_in_order_unknown_for_none() -> None:
    report = {"seconds": 0.25, "net": "n", "places": 3, "transitions": 2, "method": "explicit",
              "complete": False, "markings": 1234567, "arcs": 0, "max_tokens": None,
              "one_safe": None, "deadlock_reachable": True, "dead_transitions": None,
              "stop_reason": "more than 5 markings", "unbounded_place": "p", "other": 1}
    assert pnml_text(report).splitlines() == [
        "net                 n",
        "places              3",
        "transitions         2",
        "method              explicit",
        "complete            no",
        "markings            1,234,567",
        "arcs                0",
        "max tokens          unknown",
        "one safe            unknown",
        "deadlock reachable  yes",
        "dead transitions    unknown",
        "stop reason         more than 5 markings",
        "unbounded place     p",
        "seconds             0.25",
    ]


def test_names_and_none() -> None:
    text = pnml_text({"dead_transitions": ["t1", "t2"], "bdd_nodes": 42})
    assert text.splitlines() == ["dead transitions    t1, t2", "bdd nodes           42"]
    assert pnml_text({"dead_transitions": []}) == "dead transitions    none"
