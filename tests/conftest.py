"""What every test file shares: the ``once`` fixture, a value computed once per test run
(tests/once.py); ``dam_runs``, the dam mission run in process by case (tests/dam_runs.py); and
the order of the files, longest first, in which ``make test`` hands them to its workers."""

from __future__ import annotations

import os

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


# -- the order of the files -------------------------------------------------------------------
# ``make test`` gives pytest-xdist's two workers whole files (--dist loadfile), in collection
# order (--no-loadscope-reorder; xdist's own order, most tests first, put few long tests last:
# the Zenoh and MAVLink files ran alone at the end while the other worker waited). Longest first
# makes the workers end together: what is left at the end is short. A file's length is its
# measured seconds below (the longest files, idle 2-core machine, one worker), else an estimate
# from its tests: a test marked slow takes a second or more (its marker's meaning), another
# a few hundredths.
SECONDS: dict[str, float] = {}
SLOW_TEST, QUICK_TEST = 1.0, 0.05


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
