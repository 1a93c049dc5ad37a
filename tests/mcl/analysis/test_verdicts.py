"""The verdicts mclc keeps between calls (mcl/analysis/verdicts.py): a mission verified once is
answered from the cache while its net, its checked mission, the options and the code stay the
same, and verified again as soon as one of them changes; the key does not depend on the
process (hash seed, ids, a library built or loaded)."""

from __future__ import annotations

import hashlib
import io
import json
import os
import subprocess
import sys
from contextlib import redirect_stdout
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from app.mclc import main as mclc
from mcl.analysis import verdicts, verification
from mcl.api import compile_file, compile_source
from mcl.analysis.verification import verify_mission
from diagnostics import Source

from tests.support import REPO, subprocess_env

DAM = str(REPO / "missions" / "dam_inspection.mcl")
SHORT = "MISSION short { GoTo((0, 0, 5, 0), timeout = 60 s); Surface() }"
FAILS = "MISSION {\n  PARALLEL { GoTo((0, 0, 5, 0)) } AND { Surface() }\n}\n"  # dof-exclusive fails


class Counting:
    """verify_mission, counting its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        self.calls += 1
        return verify_mission(*args, **kwargs)


@pytest.fixture
def counting(monkeypatch: pytest.MonkeyPatch) -> Counting:
    count = Counting()
    monkeypatch.setattr(verification, "verify_mission", count)
    return count


def mission(tmp_path: Path, text: str, name: str = "m.mcl") -> str:
    path = tmp_path / name
    path.write_text(text, "utf-8")
    return str(path)


def test_a_second_call_is_answered_from_the_cache_with_the_same_report(
        folder: Path, counting: Counting, tmp_path: Path) -> None:
    compiled = compile_file(mission(tmp_path, SHORT))
    first = verdicts.verified(compiled, "auto", 1000, 1 << 30)
    again = verdicts.verified(compile_file(mission(tmp_path, SHORT)), "auto", 1000, 1 << 30)
    assert counting.calls == 1
    assert "cached" not in first.report and again.report.pop("cached") is True
    assert again == first
    assert first.report == verify_mission(compiled, "auto", max_markings=1000,
                                          max_bytes=1 << 30).to_json() | {
        "seconds": first.report["seconds"]}
    assert len(list(folder.glob("verdict-*.pickle"))) == 1


def test_a_failing_verdict_is_kept_as_failed(folder: Path, counting: Counting,
                                             tmp_path: Path) -> None:
    path = mission(tmp_path, FAILS)
    reports = [verdicts.verified(compile_file(path), "auto", 1000, 1 << 30) for _ in range(2)]
    assert counting.calls == 1
    assert [(r.ok, r.failed) for r in reports] == [(False, True)] * 2


@pytest.mark.parametrize("change", ["mission", "method", "markings", "bytes", "code"])
def test_any_change_of_what_the_verdict_depends_on_verifies_again(
        change: str, folder: Path, counting: Counting, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    path = mission(tmp_path, SHORT)
    verdicts.verified(compile_file(path), "auto", 1000, 1 << 30)
    options: list[Any] = ["auto", 1000, 1 << 30]
    if change == "mission":
        path = mission(tmp_path, SHORT.replace("60 s", "61 s"))
    elif change == "method":
        options[0] = "structural"
    elif change == "markings":
        options[1] = 999
    elif change == "bytes":
        options[2] = 1 << 29
    else:  # another version of the code that verifies
        code = tmp_path / "code"
        code.mkdir()
        (code / "petri.py").write_text("# another verifier\n", "utf-8")
        monkeypatch.setattr(verdicts, "VERIFIER_CODE", (*verdicts.VERIFIER_CODE, code))
    again = verdicts.verified(compile_file(path), *options)
    assert counting.calls == 2 and "cached" not in again.report
    assert len(list(folder.glob("verdict-*.pickle"))) == 1  # the file's entry replaced


def test_without_a_cache_every_call_verifies(monkeypatch: pytest.MonkeyPatch,
                                             counting: Counting, tmp_path: Path) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", "")
    path = mission(tmp_path, SHORT)
    for _ in range(2):
        assert "cached" not in verdicts.verified(compile_file(path), "auto", 10, 1 << 30).report
    assert counting.calls == 2


def test_the_mission_s_bytes_do_not_depend_on_the_library_being_built_or_loaded(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = Source("dam.mcl", Path(DAM).read_text("utf-8"))
    loaded = verdicts.mission_bytes(compile_source(source))
    compile_source(source)  # the library now certainly comes from the cache
    assert verdicts.mission_bytes(compile_source(source)) == loaded
    monkeypatch.setenv("MCL_CACHE_DIR", "")
    assert verdicts.mission_bytes(compile_source(source)) == loaded  # built
    other = Source("dam.mcl", source.text.replace("1.5 m;", "1.6 m;", 1))
    assert other.text != source.text
    assert verdicts.mission_bytes(compile_source(other)) != loaded


@pytest.mark.slow
def test_the_mission_s_bytes_are_the_same_in_another_process() -> None:
    here = hashlib.sha256(verdicts.mission_bytes(compile_file(DAM))).hexdigest()
    code = ("import hashlib; from mcl.api import compile_file; "
            "from mcl.analysis.verdicts import mission_bytes; "
            f"print(hashlib.sha256(mission_bytes(compile_file({DAM!r}))).hexdigest())")
    seed = "1" if os.environ.get("PYTHONHASHSEED") != "1" else "2"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=subprocess_env(PYTHONHASHSEED=seed), cwd=REPO, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == here


def test_a_cyclic_value_has_no_canonical_bytes() -> None:
    loop: list[object] = []
    loop.append([loop])
    with pytest.raises(ValueError):
        verdicts.canonical(loop)
    assert verdicts.canonical(({"a": 1}, [2])) != verdicts.canonical(({"a": 1}, [3]))


def test_mclc_says_when_its_verdict_comes_from_the_cache(folder: Path, counting: Counting,
                                                         tmp_path: Path) -> None:
    path = mission(tmp_path, SHORT)
    outputs = []
    for _ in range(2):
        out = io.StringIO()
        with redirect_stdout(out):
            assert mclc([path]) == 0
        outputs.append(out.getvalue().splitlines())
    assert counting.calls == 1
    note = "  (the verdict of an earlier call: the same net, options and code; " \
           "MCL_CACHE_DIR= verifies again)"
    assert note not in outputs[0] and outputs[1] == outputs[0] + [note]


def test_a_mission_larger_than_the_limit_is_verified_every_call(
        folder: Path, counting: Counting, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    path = mission(tmp_path, SHORT)
    size = len(compile_file(path).net.transitions)
    monkeypatch.setattr(verdicts, "MAX_TRANSITIONS", size - 1)
    for _ in range(2):
        assert "cached" not in verdicts.verified(compile_file(path), "auto", 10, 1 << 30).report
    assert counting.calls == 2 and not list(folder.glob("verdict-*"))
    monkeypatch.setattr(verdicts, "MAX_TRANSITIONS", size)
    for _ in range(2):
        verdicts.verified(compile_file(path), "auto", 10, 1 << 30)
    assert counting.calls == 3


def test_each_part_of_a_file_keeps_an_entry_of_its_own(folder: Path, counting: Counting,
                                                       tmp_path: Path) -> None:
    path = mission(tmp_path, SHORT)
    for _ in range(2):
        for part in ("leader", "follower"):
            verdicts.verified(compile_file(path), "auto", 10, 1 << 30, part)
    assert counting.calls == 2 and len(list(folder.glob("verdict-*.pickle"))) == 2


def test_a_report_s_numpy_numbers_become_python_numbers() -> None:
    assert json_of({"markings": np.int64(3), "seconds": np.float64(0.5)}) == {
        "markings": 3, "seconds": 0.5}
    with pytest.raises(TypeError, match="not JSON: object"):
        verdicts.plain(object())


def json_of(value: dict[str, Any]) -> Any:
    return json.loads(json.dumps(value, default=verdicts.plain))


def test_the_verdicts_of_the_files_verified_last_are_kept(
        folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(verdicts, "KEEP", 2)
    for name in ("a.mcl", "b.mcl", "c.mcl"):
        verdicts.verified(compile_file(mission(tmp_path, SHORT, name)), "auto", 10, 1 << 30)
    assert len(list(folder.glob("verdict-*.pickle"))) == 2
