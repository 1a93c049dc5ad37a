"""The explicit search stays inside ``--max-memory`` (issue 22, deliverable 6): a 9 KB PNML of
28 independent two-state cycles (2**28 markings, 28 successors each) took 8.1 GB under a 1
GiB budget, the numpy engine keeping every arc as three int64 and a level's marked cells
whole. Each engine now sizes what it would allocate before it does, and stops at the budget
("the memory budget of N MiB", undecided). Measured in a real ``mclc`` subprocess: its peak
resident memory, less what it held before the search (Python, numpy, numba loaded), under an
address-space limit."""

from __future__ import annotations

import json
import resource
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from petri.formats.pnml import write_pnml
from petri.net import Net
from petri.verification import reachability as rg
from tests.support import REPO, budget, subprocess_env

BUDGET_MIB = 256
ADDRESS_SPACE = 3 << 30
ENGINES = {"numba": "", "numpy": "sys.modules['numba'] = None\n"}

# The child loads everything a search needs (the engine's compiled code included) on a small
# net, notes its peak resident memory, runs mclc, and prints both peaks (KiB) last.
CHILD = """
import io, resource, sys
from contextlib import redirect_stdout
{prelude}from app.mclc import main
from petri.formats.pnml import read_pnml
from petri.verification import reachability as rg
rg.explore(read_pnml(sys.argv[2]), 100_000, engine="{engine}", arcs=False)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out = io.StringIO()
with redirect_stdout(out):
    status = main(sys.argv[1:2] + sys.argv[3:])
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(out.getvalue())
print(status, before, after)
"""


def cycles(n: int) -> Net:
    """``n`` independent cycles a_i -> b_i -> a_i, each with a token: 2**n markings."""
    net = Net(f"cycles{n}")
    for i in range(n):
        a, b = net.add_place(f"a{i}"), net.add_place(f"b{i}")
        net.initial[a] = 1
        net.add_transition(f"f{i}", [a], [b])
        net.add_transition(f"r{i}", [b], [a])
    return net


def mclc_measured(engine: str, model: Path, small: Path, *args: str) -> tuple[int, int, dict]:  # type: ignore[type-arg]
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))

    code = CHILD.format(prelude=ENGINES[engine], engine=engine)
    proc = subprocess.run([sys.executable, "-c", code, str(model), str(small), *args],
                          capture_output=True, text=True, timeout=budget(120), cwd=REPO,
                          env=subprocess_env(), stdin=subprocess.DEVNULL, preexec_fn=cap)
    assert proc.returncode == 0, proc.stderr[-2000:]
    *report, last = proc.stdout.strip().splitlines()
    status, before, after = (int(x) for x in last.split())
    return status, (after - before) * 1024, json.loads("\n".join(report))


@pytest.mark.parametrize("engine", list(ENGINES))
def test_the_explicit_search_of_independent_cycles_stays_inside_its_budget(
        engine: str, tmp_path: Path) -> None:
    if engine == "numba":
        pytest.importorskip("numba")
    model, small = tmp_path / "cycles28.pnml", tmp_path / "cycles17.pnml"
    write_pnml(cycles(28), model)
    write_pnml(cycles(17), small)  # 131,072 markings: past the bits engine's first try
    assert model.stat().st_size < 40_000
    status, used, report = mclc_measured(engine, model, small, "--method", "explicit",
                                         "--max-memory", f"{BUDGET_MIB}MiB", "--json")
    assert status == 4 and report["complete"] is False, report  # undecided, not a crash
    assert report["stop_reason"].endswith(f"the memory budget of {BUDGET_MIB} MiB")
    assert report["markings"] > 100_000  # it did search
    assert used <= BUDGET_MIB << 20, f"{used / 2**20:.0f} MiB used"


@pytest.mark.parametrize("engine", ["numba", "numpy"])
def test_each_engine_stops_at_its_byte_budget_with_all_arcs_before_it(engine: str) -> None:
    if engine == "numba":
        pytest.importorskip("numba")
    net = cycles(20)  # 1,048,576 markings, 20,971,520 arcs
    ss = rg.explore(net, 2_000_000, engine=engine, arcs=True, max_bytes=32 << 20)
    assert not ss.complete and ss.stop_reason == "the memory budget of 32 MiB"
    assert 0 < ss.expanded <= ss.n_markings < 1 << 20
    # every marking before the stop has its 20 successors, and only those are recorded
    assert ss.n_arcs == 20 * ss.expanded
    full = rg.explore(net, 2_000_000, engine=engine, arcs=False, max_bytes=32 << 20)
    assert full.stop_reason == "the memory budget of 32 MiB"
    assert full.degree is not None
    assert (full.degree[: full.expanded] == 20).all() and not full.degree[full.expanded:].any()


def test_the_symbolic_search_stops_at_its_byte_budget() -> None:
    pytest.importorskip("dd.cudd")
    from petri.verification import symbolic

    net = cycles(28)
    with pytest.raises(symbolic.SymbolicLimit, match="the BDDs outgrew the memory budget of "
                                                     "4 MiB"):
        symbolic.explore(net, max_bytes=4 << 20)  # CUDD's own tables take more
    assert symbolic.explore(net, max_bytes=64 << 20).markings == 2**28


@pytest.mark.parametrize("engine", ["numba", "numpy"])
def test_verify_stops_at_its_byte_budget_and_decides_nothing_that_holds(
        engine: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # the route of a mission's explicit verification (mcl/analysis/verification.py passes
    # mclc's --max-memory): a cut exploration, said so, nothing claimed to hold
    if engine == "numba":
        pytest.importorskip("numba")
    else:
        real = rg.explore

        def numpy_explore(net: Net, **options: Any) -> rg.StateSpace:
            return real(net, **options, engine="numpy")

        monkeypatch.setattr("petri.verification.properties.explore", numpy_explore)
    from petri.verification.properties import verify

    verdict = verify(cycles(20), max_markings=2_000_000, max_bytes=32 << 20, keep_graph=True)
    assert verdict.space is not None and verdict.space.engine == engine
    assert 0 < verdict.markings < 1 << 20
    method = verdict.results[0].method
    assert method.endswith("CUT: the memory budget of 32 MiB"), method
    assert not any(r.holds for r in verdict.results if r.name != "actions-match-behaviours")
    assert verdict.results[1].undecided and "the memory budget of 32 MiB" in verdict.results[1].message


def test_the_pnml_report_takes_the_budget_too(tmp_path: Path) -> None:
    model = tmp_path / "cycles28.pnml"
    write_pnml(cycles(28), model)
    proc = subprocess.run([sys.executable, "-m", "app.pnml_report", str(model), "--method",
                           "explicit", "--max-memory", "64MiB", "--json"], capture_output=True,
                          text=True, timeout=budget(60), cwd=REPO, env=subprocess_env(),
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr  # reported: what it could not decide is null
    report = json.loads(proc.stdout)
    assert report["complete"] is False and report["deadlock_reachable"] is None
    assert report["stop_reason"].endswith("the memory budget of 64 MiB"), report


@pytest.mark.parametrize("cycles_n, arcs", [(20, True), (2100, False)])  # ints; sets (wide)
def test_the_bits_engine_stops_at_its_byte_budget(cycles_n: int, arcs: bool) -> None:
    import tracemalloc

    net = cycles(cycles_n)
    tracemalloc.start()
    try:
        ss = rg.explore(net, 2_000_000, engine="bits", arcs=arcs, max_bytes=8 << 20)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert ss.engine == "bits" and not ss.complete
    assert ss.stop_reason == "the memory budget of 8 MiB"
    assert 0 < ss.n_markings < 2_000_000 and peak <= 8 << 20, peak
    if arcs:  # the markings before the stop have all their successors
        assert ss.n_arcs >= cycles_n * ss.expanded
        assert (ss.src[: cycles_n * ss.expanded] < ss.expanded).all()
