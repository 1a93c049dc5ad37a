"""behaviours/capabilities.py on its own: a vehicle's declaration, made from the registry.

A declaration is task-library text: the degrees of freedom, one ``behaviour`` statement per
behaviour (from its class) and one task per behaviour enabling it with every parameter it
takes. It is read back here with the task library's own loader, as the player reads it.
"""

from __future__ import annotations

from diagnostics import Source
from behaviours import ALL, capabilities, registry
from behaviours.base import DOFS
from mcl import tasklib
from tests.support import REPO


def _loaded(text: str) -> tasklib.Library:
    return tasklib.load_sources([Source("declaration", text)])


def test_a_parameters_task_enables_its_behaviour_with_every_parameter() -> None:
    goto = registry.behaviour("GoTo")
    text = capabilities.parameters_task(goto)
    assert text == ("task GoTo(x: number, y: number, z: number, yaw: number, tolerance: number)"
                    " { start: enable GoTo(x, y, z, yaw, tolerance); }\n")
    assert capabilities.parameters_task(registry.behaviour("StartCamera")) == (
        "task StartCamera() { start: enable StartCamera; }\n")


def test_a_declaration_reads_back_as_the_classes_declare() -> None:
    chosen = [registry.behaviour(n) for n in ("GoTo", "Alarms", "Surface")]
    library = _loaded(capabilities.declaration_text(chosen))
    assert library.declared_dofs == list(DOFS)
    assert {n: (b.dofs, b.events) for n, b in library.behaviours.items()} == {
        c.name: (c.drives, c.events) for c in chosen}
    for cls in chosen:
        (form,) = library.tasks[cls.name]
        assert [f.name for f in form.formals] == list(cls.parameters)
        assert [(a.kind, a.behaviour) for a in form.start] == [("enable", cls.name)]


def test_the_ictineu_declares_the_papers_behaviours_or_those_asked_for() -> None:
    every = capabilities.ictineu("ictineu")
    assert (every.vehicle, every.source) == ("ictineu", capabilities.SOURCE)
    assert list(_loaded(every.text).behaviours) == [c.name for c in ALL]
    some = capabilities.ictineu("mavlink", ["Surface", "GoTo", "FollowCable", "Nope"])
    # the paper's order; a seabed behaviour or an unknown name is not the Ictineu's
    assert list(_loaded(some.text).behaviours) == ["GoTo", "Surface"]


def test_the_simulated_stack_declares_every_registered_behaviour() -> None:
    every = capabilities.simulated("sim")
    assert list(_loaded(every.text).behaviours) == list(registry.REGISTRY)
    assert "FollowCable" in registry.REGISTRY  # the seabed ones too
    some = capabilities.simulated("sim", ["FollowCable", "Alarms"])
    assert list(_loaded(some.text).behaviours) == ["Alarms", "FollowCable"]  # registry order


def test_behaviour_statements_are_taken_from_a_library_as_written() -> None:
    text = (REPO / "mcl" / "tasks" / "ictineu.tasks").read_text("utf-8")
    statements = capabilities.behaviour_statements(text)
    first, *rest = [s.strip() for s in statements.split(";")[:-1]]  # a statement may wrap
    assert first == "dofs x, y, z, yaw"
    assert [s.split()[1] for s in rest] == [c.name for c in ALL]
    assert all(s.startswith("behaviour ") for s in rest)
    assert "//" not in statements and "task " not in statements
    only = capabilities.behaviour_statements(text, ["Surface"])
    assert only.splitlines()[0] == "dofs x, y, z, yaw;"  # the dofs are always kept
    assert [ln.split()[1] for ln in only.splitlines()[1:]] == ["Surface"]
    assert "power 80 W" in only  # as written, not rewritten
    assert set(_loaded(statements).behaviours) == {c.name for c in ALL}
