"""The Model Checking Contest's nets (../shared/mcc): every column of ORACLE.tsv, exactly, and
on the models without a row, agreement between the explicit and the symbolic search and with
the contest's own per-family verdicts (GenericPropertiesVerdict.xml)."""

from __future__ import annotations

import csv
import json
import re
import resource
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from petri.verification import reachability as rg
from petri.verification import symbolic
from petri.net import Net
from petri.formats.pnml import read_pnml
from petri.verification.pnml_report import analyse
from tests.support import REPO, budget, subprocess_env

MCC = Path(__file__).resolve().parents[3] / "shared" / "mcc"
pytestmark = pytest.mark.skipif(not (MCC / "ORACLE.tsv").is_file(),
                                reason=f"{MCC} is absent: the contest models are not available")

NUMBA = rg.default_engine() == "numba"
DD = symbolic.available()


def oracle_rows() -> list[dict[str, str]]:
    if not (MCC / "ORACLE.tsv").is_file():
        return []
    with open(MCC / "ORACLE.tsv", newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def all_models() -> list[str]:
    if not (MCC / "models").is_dir():
        return []
    return sorted(p.name.removesuffix(".tgz") for p in (MCC / "models").glob("*.tgz"))


def extract(model: str, tmp_path: Path) -> Path:
    with tarfile.open(MCC / "models" / f"{model}.tgz") as archive:
        archive.extractall(tmp_path, filter="data")
    return tmp_path / model


def speed_marks(model: str, markings: int) -> list[pytest.MarkDecorator]:
    """Run the big ones only with an engine that decides them in seconds."""
    if markings <= 100_000:
        return []
    if markings <= 20_000_000:  # explicit (the numpy fallback would take minutes)
        return [pytest.mark.skipif(not NUMBA, reason=f"{model}: {markings:,} markings need "
                                                     "the numba engine (pip install numba)")]
    return [pytest.mark.skipif(not DD or not NUMBA,
                               reason=f"{model}: {markings:,} markings need the symbolic "
                                      "search (pip install dd) after the explicit probe")]


ORACLE = [pytest.param(row, id=row["model"],
                       marks=speed_marks(row["model"], int(row["reachable_markings"])))
          for row in oracle_rows()]


@pytest.mark.slow
@pytest.mark.parametrize("row", ORACLE)
def test_oracle(row: dict[str, str], tmp_path: Path) -> None:
    net = read_pnml(extract(row["model"], tmp_path) / "model.pnml")
    report = analyse(net)
    assert report["complete"] is True
    got = {
        "reachable_markings": report["markings"],
        "reachability_graph_arcs": report["arcs"],
        "max_tokens_in_a_place": report["max_tokens"],
        "deadlock_reachable": report["deadlock_reachable"],
        "no_dead_transitions": not report["dead_transitions"],
        "one_safe": report["one_safe"],
    }
    want = {key: int(value) if value.isdigit() else value == "TRUE"
            for key, value in row.items() if key != "model"}
    assert got == want
    assert all(type(got[k]) is type(want[k]) for k in want)  # counts as ints, flags as bools


# -- the models without a row -------------------------------------------------------------

# Models with more than this many markings are left to the automatic choice alone.
CROSS_CHECK_LIMIT = 200_000
SYMBOLIC_BUDGET = 5.0  # seconds for the symbolic cross-check
# Their sizes, so that the slow ones are marked (the test itself does not trust these).
KNOWN_SIZES = {"FMS-PT-00005": 2_895_018, "Railroad-PT-010": 2_038_166,
               "SharedMemory-PT-000010": 1_830_519, "Philosophers-PT-000050": 7 * 10**23,
               "Philosophers-PT-000100": 5 * 10**47}
UNLISTED = [pytest.param(m, id=m, marks=speed_marks(m, KNOWN_SIZES.get(m, 0)))
            for m in all_models() if m not in {r["model"] for r in oracle_rows()}]


def family_verdicts(model_dir: Path) -> dict[str, str]:
    """The contest's verdicts for the model's family (all instances): "true" is informative.

    (A "false" only says that some instance of the family fails: DatabaseWithMutex is "SAFE
    false" while its instance PT-02 is 1-safe.)
    """
    text = (model_dir / "GenericPropertiesVerdict.xml").read_text(encoding="utf-8")
    return dict(re.findall(r'reference="(\w+)" value="(\w+)"', text))


def consistent(net: Net, report: dict[str, object]) -> None:
    assert report["complete"] is True
    markings, arcs = report["markings"], report["arcs"]
    assert isinstance(markings, int) and isinstance(arcs, int) and markings >= 1
    assert report["one_safe"] == (report["max_tokens"] <= 1)  # type: ignore[operator]
    dead = report["dead_transitions"]
    assert isinstance(dead, list) and set(dead) <= {t.name for t in net.transitions}
    if not report["deadlock_reachable"]:
        assert arcs >= markings  # every marking has a successor


@pytest.mark.slow
@pytest.mark.parametrize("model", UNLISTED)
def test_unlisted_model(model: str, tmp_path: Path) -> None:
    model_dir = extract(model, tmp_path)
    net = read_pnml(model_dir / "model.pnml")
    report = analyse(net)
    consistent(net, report)
    verdicts = family_verdicts(model_dir)
    if verdicts.get("SAFE") == "true":
        assert report["one_safe"] is True
    if verdicts.get("DEADLOCK") == "true":
        assert report["deadlock_reachable"] is True
    if verdicts.get("DEAD_TRANSITIONS") == "true":
        assert report["dead_transitions"]

    # Where both searches run, they must agree on everything.
    if not DD or not symbolic.is_candidate(net):
        return
    if report["markings"] > CROSS_CHECK_LIMIT:
        return
    if report["method"] == "explicit":
        try:  # BDDs blow up on some nets (BART-PT-002, TokenRing-PT-010)
            other = analyse(net, method="symbolic", symbolic_seconds=SYMBOLIC_BUDGET)
        except symbolic.SymbolicLimit:
            return
    else:
        other = analyse(net, method="explicit")
    keys = ("markings", "arcs", "max_tokens", "deadlock_reachable", "dead_transitions",
            "one_safe")
    assert {k: other[k] for k in keys} == {k: report[k] for k in keys}


@pytest.mark.skipif(not DD, reason="the symbolic search needs dd")
@pytest.mark.parametrize("model", ["Philosophers-PT-000005", "Peterson-PT-2",
                                   "RwMutex-PT-r0010w0010", "TokenRing-PT-005"])
def test_explicit_and_symbolic_agree_on_oracle_models(model: str, tmp_path: Path) -> None:
    net = read_pnml(extract(model, tmp_path) / "model.pnml")
    explicit = analyse(net, method="explicit")
    sym = analyse(net, method="symbolic")
    keys = ("markings", "arcs", "max_tokens", "deadlock_reachable", "dead_transitions",
            "one_safe")
    assert {k: sym[k] for k in keys} == {k: explicit[k] for k in keys}
    assert (explicit["method"], sym["method"]) == ("explicit", "symbolic")


@pytest.mark.skipif(not DD, reason="the symbolic search needs dd")
def test_symbolic_refuses_a_net_that_is_not_one_safe(tmp_path: Path) -> None:
    # CircularTrains-PT-012 starts 1-safe but reaches 2 tokens in a place.
    net = read_pnml(extract("CircularTrains-PT-012", tmp_path) / "model.pnml")
    assert symbolic.is_candidate(net)
    with pytest.raises(symbolic.NotOneSafe, match="second token"):
        symbolic.explore(net)
    assert analyse(net, probe=10)["method"] == "explicit"  # auto falls back


# -- a memory budget, never a MemoryError (issue 21) -------------------------------------------
# ``mclc Philosophers-PT-000050/model.pnml`` on the then default install (numpy, no numba) ended
# "internal error: MemoryError: Unable to allocate 28.1 GiB", exit 3: one BFS level's
# candidate firings at once. Run under an address-space limit, as a user's machine would be.
ADDRESS_SPACE = 3 << 30
ENGINES_RUN = {"installed": "", "without numba": "import sys; "
               "sys.modules['numba'] = None; "}  # where numba cannot be installed (numpy engine)


def mclc_limited(*args: str, prelude: str = "") -> subprocess.CompletedProcess[str]:
    """mclc in a subprocess whose address space is capped at ADDRESS_SPACE."""
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))

    code = prelude + "import sys; from app.mclc import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          timeout=budget(60), cwd=REPO, env=subprocess_env(),
                          stdin=subprocess.DEVNULL, preexec_fn=cap)


@pytest.mark.slow
@pytest.mark.parametrize("engine", list(ENGINES_RUN))
def test_philosophers_50_gets_an_answer_within_the_memory_limit(engine: str,
                                                                 tmp_path: Path) -> None:
    model = extract("Philosophers-PT-000050", tmp_path) / "model.pnml"
    run = mclc_limited(str(model), prelude=ENGINES_RUN[engine])
    assert run.returncode in (0, 1, 4), run.stdout + run.stderr
    assert "internal error" not in run.stdout + run.stderr
    if DD:  # 1-safe: the symbolic search decides it once the explicit probe is cut
        assert run.returncode == 0 and "symbolic" in run.stdout, run.stdout


@pytest.mark.parametrize("engine", list(ENGINES_RUN))
def test_the_explicit_search_stops_at_the_memory_budget(engine: str, tmp_path: Path) -> None:
    model = extract("Philosophers-PT-000050", tmp_path) / "model.pnml"
    net = read_pnml(model)
    room = rg.markings_within(net, 16 << 20, arcs=False)
    assert 0 < room < 20_000_000
    run = mclc_limited(str(model), "--method", "explicit", "--max-memory", "16MiB", "--json",
                       prelude=ENGINES_RUN[engine])
    assert run.returncode == 4, run.stdout + run.stderr  # undecided, not a crash
    report = json.loads(run.stdout)
    assert report["complete"] is False and report["status"] == "undecided"
    assert report["markings"] == room
    assert report["stop_reason"] == (f"more than {room:,} markings: the memory budget of "
                                     "16 MiB")
    assert report["deadlock_reachable"] is None  # not seen in the part explored: unknown


def test_a_budget_too_small_for_one_marking_is_undecided(tmp_path: Path) -> None:
    model = extract("Philosophers-PT-000050", tmp_path) / "model.pnml"
    net = read_pnml(model)
    report = analyse(net, method="explicit", max_bytes=1000)
    assert report["complete"] is False and report["markings"] is None
    assert report["stop_reason"].startswith("no room for markings")
