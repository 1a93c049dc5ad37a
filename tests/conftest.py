"""What every test file shares: the ``once`` fixture, a value computed once per test run
(tests/once.py); ``dam_runs``, the dam mission run in process by case (tests/dam_runs.py); a
check that no test leaves a child process of ``multiprocessing`` running; and the order of the
files, longest first, in which ``make test`` hands them to its workers."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Iterator

import pytest

from tests.dam_runs import DamRuns
from tests.once import Once


@pytest.fixture(scope="session")
def once(tmp_path_factory: pytest.TempPathFactory) -> Once:
    """:class:`Once` in this run's temporary folder, the one its xdist workers share."""
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # each worker's own is a subfolder of the run's
    return Once(base / "once")


@pytest.fixture(scope="session")
def dam_runs(once: Once) -> DamRuns:
    """The dam mission's runs in process by case (tests/dam_runs.py), once per test run."""
    return DamRuns(once)


LEFT_GRACE = 5.0  # seconds a child stopped at a test's end has to go before it counts as left


@pytest.fixture(autouse=True)
def no_child_left() -> Iterator[None]:
    """Fail the test that leaves a ``multiprocessing`` child running (a camera's worker, a
    proof): every process a test starts is stopped, and a later test that counts its own
    children (tests/app/lsp/test_proofs.py) would otherwise fail for it."""
    before = {p.pid for p in multiprocessing.active_children()}
    yield
    left = [p for p in multiprocessing.active_children() if p.pid not in before]
    for p in left:
        p.join(LEFT_GRACE)
    left = [p for p in left if p.is_alive()]
    for p in left:
        p.terminate()
        p.join(LEFT_GRACE)
    if left:
        pytest.fail(f"left running: {', '.join(f'{p.name} (pid {p.pid})' for p in left)}")


# -- the order of the files -------------------------------------------------------------------
# ``make test`` gives pytest-xdist's two workers whole files (--dist loadfile), in collection
# order (--no-loadscope-reorder; xdist's own order, most tests first, put few long tests last:
# the Zenoh and MAVLink files ran alone at the end while the other worker waited). Longest first
# makes the workers end together: what is left at the end is short. A file's length is its
# measured seconds below, else an estimate from its tests: a test marked slow takes a second or
# more on an idle machine (its marker's meaning), about 1.5 on the scale of the seconds below,
# another a few hundredths. The seconds: each package's files run by one worker, the two cores
# loaded by other work (3-6 jobs): ranks, not an idle machine's figures; files of 8 s and more.
# test_zenoh.py is put below the files of its length: it begins with the dam run in process
# that test_mavlink.py, near the top, begins with too (tests/dam_runs.py makes it once for
# both); beside it, it would wait for it.
SECONDS: dict[str, float] = {
    "tests/petri/test_mcc.py": 107,  # with ../shared/mcc, the contest's models (else skipped)
    "tests/vehicle_adapters/test_mavlink.py": 96,
    "tests/app/test_safe_exit.py": 59,
    "tests/app/test_fleet_signals.py": 40,  # real signals to fleets paced at wall time
    "tests/app/lsp/test_server.py": 58,
    "tests/vehicle_adapters/test_zenoh.py": 57,  # 62: see above
    "tests/mcl/test_routes.py": 45,
    "tests/petri/verification/test_memory_budget.py": 38,
    "tests/aal/test_zenoh_security.py": 37,
    "tests/petri/verification/test_explore_parallel.py": 33,
    "tests/mcl/test_properties.py": 32,
    "tests/app/test_fuzz_commands.py": 31,
    "tests/vehicle/control/test_stack_faults.py": 28,
    "tests/vehicle/control/test_stack_determinism.py": 25,
    "tests/petri/execution/test_status.py": 24,
    "tests/app/test_export.py": 20,
    "tests/app/test_fleet_zenoh.py": 26,  # a fleet in four processes over Zenoh
    "tests/app/test_fleet_mcm_zenoh.py": 22,  # paper 003's pair over Zenoh
    "tests/mission/test_mcm_fleet.py": 11,
    "tests/app/view/test_live_fleet.py": 12,  # a fleet over Zenoh in the browser: 10 s idle
    "tests/app/view/test_live_fleet_secured.py": 17,  # secured vehicles: 2 refusals of 2 s
    "tests/app/test_monitor_secured.py": 17,  # secured vehicles: 2 refusals of 2 s, 3 times
    "tests/app/view/test_fleet_track.py": 9,  # paper 003's fleet run, Chromium
    "tests/app/view/test_run_view.py": 28,  # wall-clock runs, Chromium, MAVLink, Zenoh
    "tests/vehicle/control/test_stack.py": 20,
    "tests/test_layers.py": 20,
    "tests/petri/verification/test_reachability.py": 20,
    "tests/mission/test_concurrent.py": 19,
    "tests/mcl/analysis/test_latches.py": 19,
    "tests/vehicle/world/test_seabed.py": 18,
    "tests/petri/execution/test_replay.py": 18,
    "tests/app/test_run_cli.py": 17,
    "tests/app/test_no_vehicle.py": 17,
    "tests/mosaic/test_mosaic_input.py": 16,
    "tests/vehicle_adapters/test_mavlink_replay.py": 16,
    "tests/app/test_streams.py": 14,
    "tests/petri/verification/test_timed.py": 14,
    "tests/petri/verification/test_explore_packed.py": 10,
    "tests/vehicle/servers/test_ardusub.py": 13,
    "tests/app/test_run_foxglove.py": 13,
    "tests/app/test_run_progress.py": 12,
    "tests/app/test_kept_reports.py": 10,  # mclc three times a case, in fresh processes
    "tests/mission/test_stop_handler.py": 9,
    "tests/app/test_bad_input.py": 9,
    "tests/petri/test_counterexamples.py": 9,
    "tests/petri/test_semantics.py": 8,
}
SLOW_TEST, QUICK_TEST = 1.5, 0.05


def file_of(item: pytest.Item) -> str:
    return item.nodeid.split("::", 1)[0]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files longest first, each file's tests in their own order (a stable sort)."""
    length: dict[str, float] = {}
    for item in items:
        test = SLOW_TEST if item.get_closest_marker("slow") else QUICK_TEST
        length[file_of(item)] = length.get(file_of(item), 0.0) + test
    length.update((name, s) for name, s in SECONDS.items() if name in length)
    items.sort(key=lambda item: -length[file_of(item)])
