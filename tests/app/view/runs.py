"""The run logs the view's tests show: the dam mission on its scripted vehicles, written as
``mcl run`` writes them (header fields included), so that ``mcl view`` accepts them."""

from __future__ import annotations

from pathlib import Path

from mcl.api import compile_file
from mission import run_mission
from tests.support import MISSIONS
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"
LEAK = MISSIONS / "vehicles" / "dam_leak.toml"


def dam_log(folder: Path, script: Path = LEAK) -> Path:
    """A run of the dam mission on the scripted vehicle ``script``: its log's path."""
    log = folder / "run.jsonl"
    run_mission(compile_file(str(DAM), require_values=True),
                InProcess(ScriptedVehicle(load_script(str(script)))), log=log,
                header={"file": str(DAM), "params": {}, "tasks": [],
                        "vehicle": f"script:{script}", "seed": 1, "inject": []},
                verify=False)
    return log
