"""mission/capabilities.py: a mission is refused, at each task call's ``file:line:col``, when
it needs a behaviour, an event or a parameter the vehicle does not declare."""

from __future__ import annotations

import pytest

from aal.messages import Declaration
from behaviours import capabilities
from diagnostics import MclError
from mcl.api import compile_file
from mission.capabilities import check_capabilities, declared_behaviours, parameters_taken
from tests.support import MISSIONS

DAM = str(MISSIONS / "dam_inspection.mcl")
PIPELINE = str(MISSIONS / "pipeline_inspection.mcl")


def test_the_simulated_vehicle_runs_every_shipped_mission() -> None:
    said = capabilities.simulated("sim")
    for mission in (DAM, PIPELINE):
        check_capabilities(compile_file(mission, require_values=True), said)  # no error


def test_a_missing_behaviour_is_named_at_each_call() -> None:
    with pytest.raises(MclError) as refused:
        check_capabilities(compile_file(PIPELINE, require_values=True),
                           capabilities.ictineu("ictineu"))
    where = [(d.span.line, d.span.col) for d in refused.value.diagnostics if d.span]
    assert where[0] == (26, 13)  # KeepAltitude(enable, altitude); (line 25 before followFor)
    text = refused.value.format()
    assert "KeepAltitude needs behaviour KeepAltitude, which vehicle ictineu does not have" \
        in text
    assert "SearchLine needs behaviour SearchLine" in text


def test_an_event_the_vehicle_never_raises_is_refused() -> None:
    text = capabilities.ictineu("v", ["GoTo"]).text.replace("reached, ", "")
    said = Declaration("v", "v.tasks", text)
    assert "reached" not in declared_behaviours(said).behaviours["GoTo"].events
    dam = compile_file(DAM, require_values=True)
    with pytest.raises(MclError, match="waits for GoTo.reached, which vehicle v never raises"):
        check_capabilities(dam, said)


def test_the_parameters_a_behaviour_takes_come_from_the_declaring_library() -> None:
    takes = parameters_taken(declared_behaviours(capabilities.simulated("sim")))
    assert takes["GoTo"] == {"x", "y", "z", "yaw", "tolerance"}
    assert takes["StartLogs"] == set()
